#include "engine/gromacs/gro.hpp"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include "engine/errors.hpp"

namespace vimd {
namespace {

constexpr std::size_t kCoordinateStart = 20;  // %5d%-5s%5s%5d precede the coordinates

std::string_view trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t");
  if (first == std::string_view::npos) return {};
  const auto last = s.find_last_not_of(" \t");
  return s.substr(first, last - first + 1);
}

std::optional<double> parse_double(std::string_view s) {
  s = trim(s);
  double value = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  if (s.empty() || ec != std::errc() || end != s.data() + s.size() || !std::isfinite(value)) return std::nullopt;
  return value;
}

std::optional<long> parse_long(std::string_view s) {
  s = trim(s);
  long value = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  if (s.empty() || ec != std::errc() || end != s.data() + s.size()) return std::nullopt;
  return value;
}

class GroLines {
 public:
  explicit GroLines(const std::filesystem::path& file) : name_(file.string()), in_(file) {
    if (!in_) throw InputError(name_, 0, "cannot open structure file: " + std::string(std::strerror(errno)));
  }
  // Returns false at end of file; line_number() is then the line that would have come next.
  bool next(std::string& line) {
    ++line_number_;
    if (!std::getline(in_, line)) return false;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return true;
  }
  int line_number() const { return line_number_; }
  [[noreturn]] void fail(const std::string& problem) const { throw InputError(name_, line_number_, problem); }

 private:
  std::string name_;
  std::ifstream in_;
  int line_number_ = 0;
};

// GROMACS derives the field width from the distance between the first two decimal points of the
// first atom line, which is what makes the -ndec variants readable.
std::size_t field_width(const std::string& line, const GroLines& lines) {
  const auto p1 = line.find('.', kCoordinateStart);
  const auto p2 = p1 == std::string::npos ? p1 : line.find('.', p1 + 1);
  const auto p3 = p2 == std::string::npos ? p2 : line.find('.', p2 + 1);
  if (p3 == std::string::npos) lines.fail("cannot find the decimal points of x, y and z in the first atom line");
  if (p3 - p2 != p2 - p1) lines.fail("the decimal points of x, y and z are not evenly spaced (not a .gro atom line?)");
  return p2 - p1;
}

Vec3 read_triplet(const std::string& line, std::size_t start, std::size_t width, const char* what,
                  const GroLines& lines) {
  Vec3 r;
  for (int k = 0; k < 3; ++k) {
    const std::size_t at = start + k * width;
    const auto value = parse_double(std::string_view(line).substr(at, width));
    if (!value)
      lines.fail(std::string("cannot read ") + what + " " + "xyz"[k] + " from columns " + std::to_string(at + 1) + "-" +
                 std::to_string(at + width) + ": '" + line.substr(at, width) + "'");
    r[k] = *value;
  }
  return r;
}

Box read_box(const std::string& line, const GroLines& lines) {
  std::vector<double> numbers;
  std::size_t pos = 0;
  while (true) {
    pos = line.find_first_not_of(" \t", pos);
    if (pos == std::string::npos) break;
    const auto end = std::min(line.find_first_of(" \t", pos), line.size());
    const auto value = parse_double(std::string_view(line).substr(pos, end - pos));
    if (!value) lines.fail("cannot read box line: '" + line.substr(pos, end - pos) + "' is not a number");
    numbers.push_back(*value);
    pos = end;
  }
  if (numbers.size() != 3 && numbers.size() != 9)
    lines.fail("box line must have 3 numbers (or 9 for a triclinic box), found " + std::to_string(numbers.size()));
  for (std::size_t k = 3; k < numbers.size(); ++k)
    if (numbers[k] != 0) lines.fail("triclinic boxes are not supported (non-zero off-diagonal box vector components)");
  Box box;
  box.length = Vec3(numbers[0], numbers[1], numbers[2]);
  if (box.length.minCoeff() < 0) lines.fail("box lengths must not be negative");
  return box;
}

}  // namespace

GroFrame read_gro(const std::filesystem::path& file) {
  GroLines lines(file);
  GroFrame frame;
  std::string line;
  if (!lines.next(frame.title)) lines.fail("empty file: expected a title line");
  if (!lines.next(line)) lines.fail("file ends before the number-of-atoms line");
  const auto count = parse_long(line);
  if (!count || *count < 0) lines.fail("expected the number of atoms, got '" + line + "'");
  // Each atom line holds at least 20 + 3 decimal points; refuse absurd counts before allocating.
  if (*count > static_cast<long>(std::filesystem::file_size(file) / 23))
    lines.fail("the file is too short to hold " + std::to_string(*count) + " atoms (truncated file?)");
  const int n = static_cast<int>(*count);

  frame.residue_names.resize(n);
  frame.atom_names.resize(n);
  frame.residue_numbers.resize(n);
  frame.x.resize(3, n);
  std::size_t width = 0;
  bool velocities = false;
  for (int i = 0; i < n; ++i) {
    if (!lines.next(line))
      lines.fail("file ends after " + std::to_string(i) + " of " + std::to_string(n) + " atoms (truncated file?)");
    if (i == 0) width = field_width(line, lines);
    if (line.size() < kCoordinateStart + 3 * width)
      lines.fail("atom line too short: expected at least " + std::to_string(kCoordinateStart + 3 * width) +
                 " characters, found " + std::to_string(line.size()));
    const auto residue_number = parse_long(std::string_view(line).substr(0, 5));
    if (!residue_number) lines.fail("cannot read the residue number from columns 1-5: '" + line.substr(0, 5) + "'");
    frame.residue_numbers[i] = static_cast<int>(*residue_number);
    frame.residue_names[i] = std::string(trim(std::string_view(line).substr(5, 5)));
    frame.atom_names[i] = std::string(trim(std::string_view(line).substr(10, 5)));
    frame.x.col(i) = read_triplet(line, kCoordinateStart, width, "coordinate", lines);

    // Velocities are present when the first atom line has anything after its coordinates; from
    // then on every atom must have them.
    const std::size_t v_start = kCoordinateStart + 3 * width;
    const bool has_more = !trim(std::string_view(line).substr(v_start)).empty();
    if (i == 0 && has_more) {
      velocities = true;
      frame.v.emplace(3, n);
    }
    if (!velocities && has_more)
      lines.fail("this atom line has velocities (or other text after z) but the first atom line (line 3) has none: "
                 "give velocities on every atom line or on none");
    if (velocities) {
      if (line.size() < v_start + 3 * width)
        lines.fail(i == 0 ? "the text after z, '" + std::string(trim(std::string_view(line).substr(v_start))) +
                                "', is not three velocities of " + std::to_string(width) +
                                " columns each: give velocities on every atom line or nothing after z"
                          : "no velocities on this atom line, but the first atom line has them");
      frame.v->col(i) = read_triplet(line, v_start, width, "velocity", lines);
    }
  }
  if (!lines.next(line) || trim(line).empty()) lines.fail("missing box line after " + std::to_string(n) + " atoms");
  frame.box = read_box(line, lines);
  return frame;
}

void write_gro(const std::filesystem::path& file, const std::string& title, const System& system, const Coords& x,
               const Coords* v, const Box& box) {
  const int n = static_cast<int>(x.cols());
  if (system.n_atoms() != n || (v && v->cols() != n))
    throw std::invalid_argument("write_gro: " + std::to_string(system.n_atoms()) + " atoms in the system but " +
                                std::to_string(n) + " positions" +
                                (v ? " and " + std::to_string(v->cols()) + " velocities" : std::string()));
  const std::filesystem::path partial = file.string() + ".partial";
  std::FILE* out = std::fopen(partial.c_str(), "w");
  if (!out) throw std::runtime_error("cannot write " + partial.string() + ": " + std::strerror(errno));
  // A newline inside the title would break the fixed line layout.
  std::string first_line = title.substr(0, title.find('\n'));
  std::fprintf(out, "%s\n%5d\n", first_line.c_str(), n);
  for (int i = 0; i < n; ++i) {
    std::fprintf(out, "%5d%-5.5s%5.5s%5d%8.3f%8.3f%8.3f", system.residue_numbers[i] % 100000,
                 system.residue_names[i].c_str(), system.atom_names[i].c_str(), (i + 1) % 100000, x(0, i), x(1, i),
                 x(2, i));
    if (v) std::fprintf(out, "%8.4f%8.4f%8.4f", (*v)(0, i), (*v)(1, i), (*v)(2, i));
    std::fputc('\n', out);
  }
  std::fprintf(out, "%10.5f%10.5f%10.5f\n", box.length[0], box.length[1], box.length[2]);
  const bool failed = std::ferror(out) != 0;
  if (std::fclose(out) != 0 || failed) {
    std::filesystem::remove(partial);
    throw std::runtime_error("error writing " + partial.string() + " (disk full?)");
  }
  std::filesystem::rename(partial, file);
}

std::vector<std::string> apply_structure(System& system, const GroFrame& frame, const std::filesystem::path& gro_file,
                                         const std::filesystem::path& top_file) {
  const int n = static_cast<int>(frame.x.cols());
  if (n != system.n_atoms())
    throw InputError(gro_file.string(), 2,
                     "structure has " + std::to_string(n) + " atoms but the topology has " + std::to_string(system.n_atoms()) +
                         " (check the molecule counts in [ molecules ] of " + top_file.string() + ")");
  system.box = frame.box;
  // As grompp: differing names are a warning, and the topology's names are the ones used.
  constexpr int kListed = 20;
  std::string listed;
  int mismatches = 0, first_line = 0;
  for (int i = 0; i < n; ++i) {
    // .gro keeps only 5 characters of a name.
    if (frame.atom_names[i] == system.atom_names[i].substr(0, 5)) continue;
    if (++mismatches == 1) first_line = i + 3;
    if (mismatches <= kListed)
      listed += "\n  line " + std::to_string(i + 3) + ": atom " + std::to_string(i + 1) + " is '" + frame.atom_names[i] +
                "' here, '" + system.atom_names[i] + "' in the topology";
  }
  if (mismatches == 0) return {};
  if (mismatches > kListed) listed += "\n  (" + std::to_string(mismatches - kListed) + " more)";
  return {gro_file.string() + ":" + std::to_string(first_line) + ": " + std::to_string(mismatches) +
          " atom name(s) do not match the topology " + top_file.string() +
          "; the topology's names are used (is the structure in the topology's atom order?)" + listed};
}

}  // namespace vimd
