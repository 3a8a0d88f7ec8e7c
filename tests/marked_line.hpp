#pragma once
// Malformed test inputs mark the line their error must point to with a comment such as
// "; ERROR" (topologies) or "# ERROR" (TOML); tests look the line up instead of hard-coding it.
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

inline int marked_line(const std::filesystem::path& file, const std::string& marker) {
  std::ifstream in(file);
  std::string line;
  for (int number = 1; std::getline(in, line); ++number)
    if (line.find(marker) != std::string::npos) return number;
  throw std::runtime_error("test data " + file.string() + " has no line marked '" + marker + "'");
}
