#include "engine/gromacs/top_fields.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>

namespace vimd::top {

std::string format_number(double value) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", value);
  return buf;
}

Fields::Fields(const LogicalLine& line, const std::string& section)
    : words_(split_words(line.text)), where_(line.where), section_(section) {}

void Fields::require(std::size_t n, const char* layout) const {
  if (words_.size() < n)
    fail(where_, "[ " + section_ + " ] line has " + std::to_string(words_.size()) + " fields, expected at least " +
                     std::to_string(n) + ": " + layout);
}

double Fields::number(std::size_t k, const char* what) const {
  double value = 0;
  const std::string& s = words_.at(k);
  const char* begin = s.data() + (s.size() > 1 && s[0] == '+');  // from_chars rejects a leading '+'
  const auto [end, ec] = std::from_chars(begin, s.data() + s.size(), value);
  if (ec != std::errc() || end != s.data() + s.size() || !std::isfinite(value))
    fail(where_, "[ " + section_ + " ] field " + std::to_string(k + 1) + " (" + what + ") is not a number: '" + s +
                     "'");
  return value;
}

long Fields::integer(std::size_t k, const char* what) const {
  long value = 0;
  const std::string& s = words_.at(k);
  const char* begin = s.data() + (s.size() > 1 && s[0] == '+');
  const auto [end, ec] = std::from_chars(begin, s.data() + s.size(), value);
  if (ec != std::errc() || end != s.data() + s.size())
    fail(where_, "[ " + section_ + " ] field " + std::to_string(k + 1) + " (" + what + ") is not an integer: '" + s +
                     "'");
  return value;
}

int Fields::atom(std::size_t k, const MoleculeType& molecule) const {
  const long index = integer(k, "atom number");
  if (index < 1 || index > static_cast<long>(molecule.atoms.size()))
    fail(where_, "atom number " + std::to_string(index) + " is out of range: molecule type '" + molecule.name +
                     "' has " + std::to_string(molecule.atoms.size()) + " atoms (defined so far)");
  return static_cast<int>(index - 1);
}

std::vector<double> Fields::numbers_from(std::size_t first, const char* what) const {
  std::vector<double> values;
  for (std::size_t k = first; k < words_.size(); ++k) values.push_back(number(k, what));
  return values;
}

}  // namespace vimd::top
