#pragma once
// One data line of a topology section split into fields, with typed accessors whose errors name
// the section and the column (FILE:LINE: problem).
#include <cstddef>
#include <string>
#include <vector>

#include "engine/gromacs/top_model.hpp"
#include "engine/gromacs/top_preprocessor.hpp"

namespace vimd::top {

// A number as the error messages print it (%g).
std::string format_number(double value);

class Fields {
 public:
  Fields(const LogicalLine& line, const std::string& section);
  std::size_t size() const { return words_.size(); }
  const std::string& operator[](std::size_t k) const { return words_[k]; }
  const Where& where() const { return where_; }
  // The section's name as written in its header, lower case.
  const std::string& section() const { return section_; }

  // At least n fields, else an error that shows the expected layout.
  void require(std::size_t n, const char* layout) const;
  double number(std::size_t k, const char* what) const;
  long integer(std::size_t k, const char* what) const;
  // A 1-based atom number inside the current molecule, returned 0-based.
  int atom(std::size_t k, const MoleculeType& molecule) const;
  // Numbers after the first `first` fields.
  std::vector<double> numbers_from(std::size_t first, const char* what) const;
  [[noreturn]] void error(const std::string& problem) const { fail(where_, problem); }

 private:
  std::vector<std::string> words_;
  Where where_;
  std::string section_;
};

}  // namespace vimd::top
