#include "engine/checkpoint.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>

#include "engine/errors.hpp"
#include "engine/fingerprint.hpp"

namespace vimd {
namespace {

// Native byte order: a checkpoint continues a run on the machine (or kind of machine) it stopped on.
constexpr char kMagic[8] = {'V', 'I', 'M', 'D', 'C', 'P', 'T', '2'};
// Version 1 had no checksum and no segments.
constexpr char kMagicWithoutChecksum[8] = {'V', 'I', 'M', 'D', 'C', 'P', 'T', '1'};
constexpr char kEnd[8] = {'E', 'N', 'D', 'V', 'I', 'M', 'D', '.'};

[[noreturn]] void unusable(const std::string& file, const std::string& what) {
  throw InputError(file, 0, "not a usable vimd checkpoint (" + what + ")");
}

[[noreturn]] void write_failed(const std::filesystem::path& file, const std::string& what) {
  throw std::runtime_error(file.string() + ": cannot write the checkpoint (" + what + "): " + std::strerror(errno));
}

// Streams the checkpoint to a file descriptor through a small buffer, arrays straight from their own
// memory: the last checkpoint comes on top of everything a run holds, and a copy of the whole file
// would raise the run's peak memory by its size.
class Writer {
 public:
  Writer(int fd, std::filesystem::path file) : fd_(fd), file_(std::move(file)) { buffer_.reserve(kBuffer); }
  template <class T>
  void raw(const T& x) {
    put(&x, sizeof x);
  }
  void text(const std::string& s) {
    raw<std::uint64_t>(s.size());
    put(s.data(), s.size());
  }
  void doubles(const double* p, std::size_t n) {
    raw<std::uint64_t>(n);
    put(p, n * sizeof(double));
  }
  void coords(const Coords& c) { doubles(c.data(), c.size()); }
  void pairs(const std::vector<std::pair<std::string, std::string>>& list) {
    raw<std::uint64_t>(list.size());
    for (const auto& [key, value] : list) text(key), text(value);
  }
  void carried(const Carried& c) {
    raw<std::uint64_t>(c.items.size());
    for (const auto& [name, values] : c.items) {
      text(name);
      doubles(values.data(), values.size());
    }
  }
  // The checksum of everything put so far, then everything out to the file.
  void seal() {
    const std::uint64_t sum = checksum_.value();
    put(&sum, sizeof sum);
    send(buffer_.data(), buffer_.size());
    buffer_.clear();
  }

 private:
  static constexpr std::size_t kBuffer = 1 << 16;
  void put(const void* p, std::size_t n) {
    checksum_.add_bytes(p, n);
    if (buffer_.size() + n > kBuffer) {
      send(buffer_.data(), buffer_.size());
      buffer_.clear();
    }
    if (n >= kBuffer)
      send(static_cast<const char*>(p), n);
    else
      buffer_.append(static_cast<const char*>(p), n);
  }
  void send(const char* p, std::size_t n) {
    while (n > 0) {
      const ssize_t done = ::write(fd_, p, n);
      if (done < 0 && errno == EINTR) continue;
      if (done <= 0) {
        if (done == 0) errno = ENOSPC;
        const int saved = errno;
        ::close(fd_);
        errno = saved;
        write_failed(file_, "write");
      }
      p += done;
      n -= static_cast<std::size_t>(done);
    }
  }
  int fd_;
  std::filesystem::path file_;
  std::string buffer_;
  Fingerprint checksum_;
};

class Reader {
 public:
  Reader(std::string bytes, std::string file) : bytes_(std::move(bytes)), file_(std::move(file)) {}
  template <class T>
  T raw() {
    T x;
    take(&x, sizeof x);
    return x;
  }
  std::string text() {
    std::string s(count(1), '\0');
    take(s.data(), s.size());
    return s;
  }
  std::vector<double> doubles() {
    std::vector<double> v(count(sizeof(double)));
    take(v.data(), v.size() * sizeof(double));
    return v;
  }
  Coords coords() {
    const std::vector<double> v = doubles();
    if (v.size() % 3) fail("an array is not 3 x N");
    return Eigen::Map<const Coords>(v.data(), 3, static_cast<Eigen::Index>(v.size() / 3));
  }
  std::vector<std::pair<std::string, std::string>> pairs() {
    std::vector<std::pair<std::string, std::string>> list;
    const std::size_t n = count(2 * sizeof(std::uint64_t));  // each pair: two lengths at least
    for (std::size_t k = 0; k < n; ++k) {
      std::string key = text();
      list.emplace_back(std::move(key), text());
    }
    return list;
  }
  Carried carried() {
    Carried c;
    const std::size_t n = count(1);
    for (std::size_t k = 0; k < n; ++k) {
      std::string name = text();
      c.items[name] = doubles();
    }
    return c;
  }
  bool at_end() const { return pos_ == bytes_.size(); }
  [[noreturn]] void fail(const std::string& what) const { unusable(file_, what); }

 private:
  std::size_t count(std::size_t element) {
    const auto n = raw<std::uint64_t>();
    if (n > (bytes_.size() - pos_) / element) fail("truncated or damaged");
    return static_cast<std::size_t>(n);
  }
  void take(void* out, std::size_t n) {
    if (n > bytes_.size() - pos_) fail("truncated or damaged");
    if (n == 0) return;  // out may be an empty vector's null data(), which memcpy must not get
    std::memcpy(out, bytes_.data() + pos_, n);
    pos_ += n;
  }
  std::string bytes_, file_;
  std::size_t pos_ = 0;
};

}  // namespace

std::uint64_t checkpoint_checksum(const void* data, std::size_t n) {
  Fingerprint checksum;
  checksum.add_bytes(data, n);
  return checksum.value();
}

void write_checkpoint(const std::filesystem::path& file, const Checkpoint& cp) {
  // A crash at any point leaves either the old checkpoint or the new one, never half of one.
  const std::filesystem::path fresh = file.string() + ".new";
  const int fd = ::open(fresh.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) write_failed(fresh, "open");
  Writer w(fd, fresh);
  w.raw(kMagic);
  w.pairs(cp.identity);
  w.raw<std::int64_t>(cp.first_step);
  w.raw<std::int64_t>(cp.last_step);
  const State& s = cp.state;
  w.raw<std::int64_t>(s.step);
  w.raw(s.time);
  w.raw(s.potential);
  w.doubles(s.energy_terms.data(), s.energy_terms.size());
  w.coords(s.q);
  w.coords(s.v);
  w.coords(s.f);
  w.carried(cp.integrator);
  w.carried(cp.force_field);
  w.carried(cp.totals);
  w.raw<std::uint64_t>(cp.observers.size());
  for (const Carried& c : cp.observers) w.carried(c);
  w.raw<std::uint64_t>(cp.segments.size());
  for (const RunSegment& segment : cp.segments) {
    w.raw<std::int64_t>(segment.first_step);
    w.pairs(segment.platform);
  }
  w.raw(kEnd);
  w.seal();
  if (::fsync(fd) != 0) {
    const int saved = errno;
    ::close(fd);
    errno = saved;
    write_failed(fresh, "fsync");
  }
  if (::close(fd) != 0) write_failed(fresh, "close");
  if (std::rename(fresh.c_str(), file.c_str()) != 0) write_failed(file, "rename");
  const std::filesystem::path dir = file.has_parent_path() ? file.parent_path() : std::filesystem::path(".");
  const int dir_fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir_fd >= 0) {  // makes the rename durable; best effort where directories cannot be opened
    ::fsync(dir_fd);
    ::close(dir_fd);
  }
}

Checkpoint read_checkpoint(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw InputError(file.string(), 0, "cannot open the checkpoint (is this the directory of a stopped run?)");
  std::string bytes(std::istreambuf_iterator<char>(in), {});
  // The magic number first, so that an old or foreign file is named as such rather than as damaged.
  if (bytes.size() >= sizeof kMagic && std::memcmp(bytes.data(), kMagicWithoutChecksum, sizeof kMagic) == 0)
    throw InputError(file.string(), 0,
                     "written by an older vimd, without a checksum, so it cannot be verified: refusing to continue "
                     "from it (start the run afresh with --overwrite)");
  if (bytes.size() < sizeof kMagic + sizeof(std::uint64_t))
    unusable(file.string(), "truncated: " + std::to_string(bytes.size()) + " bytes");
  if (std::memcmp(bytes.data(), kMagic, sizeof kMagic) != 0) unusable(file.string(), "wrong magic number");
  const std::size_t body = bytes.size() - sizeof(std::uint64_t);
  std::uint64_t stored;
  std::memcpy(&stored, bytes.data() + body, sizeof stored);
  if (checkpoint_checksum(bytes.data(), body) != stored)
    unusable(file.string(), "damaged or truncated: its checksum does not match its " + std::to_string(bytes.size()) +
                                " bytes");
  bytes.resize(body);
  Reader r(std::move(bytes), file.string());
  for (std::size_t k = 0; k < sizeof kMagic; ++k) r.raw<char>();  // checked above
  Checkpoint cp;
  cp.identity = r.pairs();
  cp.first_step = r.raw<std::int64_t>();
  cp.last_step = r.raw<std::int64_t>();
  State& s = cp.state;
  s.step = r.raw<std::int64_t>();
  s.time = r.raw<double>();
  s.potential = r.raw<double>();
  s.energy_terms = r.doubles();
  s.q = r.coords();
  s.v = r.coords();
  s.f = r.coords();
  cp.integrator = r.carried();
  cp.force_field = r.carried();
  cp.totals = r.carried();
  const auto n_observers = r.raw<std::uint64_t>();
  for (std::uint64_t k = 0; k < n_observers && k < 1000; ++k) cp.observers.push_back(r.carried());
  const auto n_segments = r.raw<std::uint64_t>();
  for (std::uint64_t k = 0; k < n_segments && k < 100000; ++k) {
    RunSegment& segment = cp.segments.emplace_back();
    segment.first_step = r.raw<std::int64_t>();
    segment.platform = r.pairs();
  }
  char end[sizeof kEnd];
  for (char& c : end) c = r.raw<char>();
  if (std::memcmp(end, kEnd, sizeof kEnd) != 0 || !r.at_end()) r.fail("damaged end marker");
  if (s.q.cols() != s.v.cols() || s.q.cols() != s.f.cols()) r.fail("inconsistent array sizes");
  return cp;
}

void check_identity(const std::filesystem::path& file, const RunIdentity& checkpoint, const RunIdentity& here) {
  std::string differences;
  auto add = [&](const std::string& text) { differences += (differences.empty() ? "" : "; ") + text; };
  for (const auto& [key, value] : here) {
    std::string stored;
    bool found = false;
    for (const auto& [k, v] : checkpoint)
      if (k == key) stored = v, found = true;
    if (!found)
      add(key + " missing in the checkpoint");
    else if (stored != value)
      add(key + ": " + stored + " in the checkpoint, " + value + " here");
  }
  if (!differences.empty())
    throw InputError(file.string(), 0,
                     "the checkpoint belongs to another system or configuration, refusing to continue: " + differences);
}

}  // namespace vimd
