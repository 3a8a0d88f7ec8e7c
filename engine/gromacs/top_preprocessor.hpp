#pragma once
// GROMACS's .top preprocessor (#include, #define, #undef, #ifdef, #ifndef, #else, #endif, ';'
// comments, '\' continuation): the logical lines of the active branches, each with the file and
// line it started on, for the topology parser.
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace vimd::top {

// A place in a topology file, for error messages.
struct Where {
  std::string file;
  int line = 0;
  std::string str() const { return file + ":" + std::to_string(line); }
};

// InputError at `where`.
[[noreturn]] void fail(const Where& where, const std::string& problem);

std::string_view trim(std::string_view s);
std::vector<std::string> split_words(std::string_view s);

// A line with continuations joined, the comment stripped and macros substituted.
struct LogicalLine {
  std::string text;
  Where where;
};

class Preprocessor {
 public:
  // `library_dirs` are searched for an #include after the including file's own directory.
  Preprocessor(const std::filesystem::path& top, std::vector<std::filesystem::path> library_dirs);
  ~Preprocessor();
  // The next logical line; false at the end of the top file.
  bool next(LogicalLine& out);

 private:
  class Reader;
  std::unique_ptr<Reader> reader_;
};

}  // namespace vimd::top
