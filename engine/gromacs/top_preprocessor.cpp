#include "engine/gromacs/top_preprocessor.hpp"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <unordered_map>

#include "engine/errors.hpp"

namespace vimd::top {
namespace fs = std::filesystem;

[[noreturn]] void fail(const Where& where, const std::string& problem) {
  throw InputError(where.file, where.line, problem);
}

std::string_view trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t\r\n\f\v");
  if (first == std::string_view::npos) return {};
  const auto last = s.find_last_not_of(" \t\r\n\f\v");
  return s.substr(first, last - first + 1);
}

std::vector<std::string> split_words(std::string_view s) {
  std::vector<std::string> words;
  std::size_t pos = 0;
  while ((pos = s.find_first_not_of(" \t\r\n\f\v", pos)) != std::string_view::npos) {
    const auto end = std::min(s.find_first_of(" \t\r\n\f\v", pos), s.size());
    words.emplace_back(s.substr(pos, end - pos));
    pos = end;
  }
  return words;
}

namespace {

bool is_word_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

}  // namespace

class Preprocessor::Reader {
 public:
  Reader(const fs::path& top, std::vector<fs::path> library_dirs) : library_dirs_(std::move(library_dirs)) {
    open(top, nullptr);
  }

  bool next(LogicalLine& out) {
    while (!files_.empty()) {
      OpenFile& file = *files_.back();
      std::string text;
      int first_line = 0;
      if (!read_logical(file, text, first_line)) {
        if (!file.conditionals.empty())
          fail(file.conditionals.back().where, "#ifdef/#ifndef is not closed by an #endif in the same file");
        files_.pop_back();
        continue;
      }
      Where where{file.name, first_line};
      if (const auto semicolon = text.find(';'); semicolon != std::string::npos) text.erase(semicolon);
      const std::string_view line = trim(text);
      if (line.empty()) continue;
      if (line.front() == '#') {
        directive(file, line, where);  // may push an included file; `file` is not used afterwards
        continue;
      }
      if (!active(file)) continue;
      out.text = substitute(line);
      out.where = std::move(where);
      return true;
    }
    return false;
  }

 private:
  struct Conditional {
    bool condition;       // the #ifdef/#ifndef test, inverted by #else
    bool parent_active;   // whether the enclosing region is read at all
    bool seen_else = false;
    Where where;
  };
  struct OpenFile {
    std::ifstream in;
    fs::path path;
    std::string name;
    int line = 0;
    std::vector<Conditional> conditionals;  // #ifdef nesting must close within one file
  };

  static bool active(const OpenFile& file) {
    return file.conditionals.empty() || (file.conditionals.back().parent_active && file.conditionals.back().condition);
  }

  void open(const fs::path& path, const Where* included_from) {
    if (files_.size() >= 64) fail(*included_from, "#include nested more than 64 deep (recursive include?)");
    auto file = std::make_unique<OpenFile>();
    file->path = path;
    file->name = path.string();
    file->in.open(path);
    if (!file->in) {
      if (included_from) fail(*included_from, "cannot open included file " + path.string());
      throw InputError(path.string(), 0, "cannot open topology file");
    }
    files_.push_back(std::move(file));
  }

  static bool read_logical(OpenFile& file, std::string& text, int& first_line) {
    std::string physical;
    if (!std::getline(file.in, physical)) return false;
    first_line = ++file.line;
    text = physical;
    // A trailing backslash continues the line on the next one.
    while (true) {
      const auto end = text.find_last_not_of(" \t\r");
      if (end == std::string::npos || text[end] != '\\') break;
      text.erase(end);
      if (!std::getline(file.in, physical)) break;
      ++file.line;
      text += ' ';
      text += physical;
    }
    if (!text.empty() && text.back() == '\r') text.pop_back();
    return true;
  }

  void directive(OpenFile& file, std::string_view line, const Where& where) {
    line.remove_prefix(1);
    line = trim(line);
    std::size_t name_end = 0;
    while (name_end < line.size() && std::isalpha(static_cast<unsigned char>(line[name_end]))) ++name_end;
    const std::string name(line.substr(0, name_end));
    const std::string_view rest = trim(line.substr(name_end));

    if (name == "ifdef" || name == "ifndef") {
      const auto words = split_words(rest);
      if (words.size() != 1) fail(where, "#" + name + " needs exactly one macro name");
      const bool defined = defines_.count(words[0]) > 0;
      file.conditionals.push_back({defined == (name == "ifdef"), active(file), false, where});
      return;
    }
    if (name == "else" || name == "endif") {
      if (file.conditionals.empty()) fail(where, "#" + name + " without a matching #ifdef/#ifndef");
      if (name == "endif") {
        file.conditionals.pop_back();
        return;
      }
      Conditional& c = file.conditionals.back();
      if (c.seen_else) fail(where, "second #else for the #ifdef at " + c.where.str());
      c.seen_else = true;
      c.condition = !c.condition;
      return;
    }
    if (!active(file)) return;  // other directives in a skipped branch are not evaluated

    if (name == "include") {
      const char close = rest.empty() ? '\0' : (rest.front() == '"' ? '"' : rest.front() == '<' ? '>' : '\0');
      const auto end = close ? rest.find(close, 1) : std::string_view::npos;
      if (end == std::string_view::npos || end == 1)
        fail(where, "#include needs a file name in quotes, e.g. #include \"forcefield.itp\"");
      open(resolve_include(std::string(rest.substr(1, end - 1)), file.path, where), &where);
      return;
    }
    if (name == "define") {
      std::size_t macro_end = 0;
      while (macro_end < rest.size() && is_word_char(rest[macro_end])) ++macro_end;
      if (macro_end == 0) fail(where, "#define needs a macro name");
      defines_[std::string(rest.substr(0, macro_end))] = std::string(trim(rest.substr(macro_end)));
      return;
    }
    if (name == "undef") {
      const auto words = split_words(rest);
      if (words.size() != 1) fail(where, "#undef needs exactly one macro name");
      defines_.erase(words[0]);
      return;
    }
    fail(where, "unsupported preprocessor directive '#" + name +
                    "' (supported: #include, #define, #undef, #ifdef, #ifndef, #else, #endif)");
  }

  fs::path resolve_include(const std::string& name, const fs::path& including, const Where& where) const {
    const fs::path requested(name);
    std::vector<fs::path> candidates;
    if (requested.is_absolute()) {
      candidates.push_back(requested);
    } else {
      candidates.push_back(including.parent_path() / requested);
      for (const auto& dir : library_dirs_) candidates.push_back(dir / requested);
    }
    std::string searched;
    for (const auto& candidate : candidates) {
      std::error_code ec;
      if (fs::is_regular_file(candidate, ec)) return candidate.lexically_normal();
      searched += (searched.empty() ? "" : ", ") + candidate.parent_path().string();
    }
    fail(where, "cannot find #include \"" + name + "\" (searched " + searched + "; set GMXLIB to add a directory)");
  }

  // GROMACS replaces every whole word that names a macro with a non-empty value.
  std::string substitute(std::string_view line) const {
    std::string out;
    out.reserve(line.size());
    std::size_t pos = 0;
    while (pos < line.size()) {
      if (!is_word_char(line[pos])) {
        out += line[pos++];
        continue;
      }
      std::size_t end = pos;
      while (end < line.size() && is_word_char(line[end])) ++end;
      const std::string word(line.substr(pos, end - pos));
      const auto it = defines_.find(word);
      out += (it != defines_.end() && !it->second.empty()) ? it->second : word;
      pos = end;
    }
    return out;
  }

  std::vector<std::unique_ptr<OpenFile>> files_;
  std::unordered_map<std::string, std::string> defines_;
  std::vector<fs::path> library_dirs_;
};

Preprocessor::Preprocessor(const fs::path& top, std::vector<fs::path> library_dirs)
    : reader_(std::make_unique<Reader>(top, std::move(library_dirs))) {}
Preprocessor::~Preprocessor() = default;
bool Preprocessor::next(LogicalLine& out) { return reader_->next(out); }

}  // namespace vimd::top
