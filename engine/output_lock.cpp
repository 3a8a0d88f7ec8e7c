#include "engine/output_lock.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <string>

#include "engine/errors.hpp"

namespace vimd {
namespace {

// "pid 123 on host node7, started 2026-12-08 02:14:19 UTC"
std::string holder_text() {
  char host[256] = "unknown host";
  ::gethostname(host, sizeof host - 1);
  const std::time_t now = std::time(nullptr);
  char when[40];
  std::strftime(when, sizeof when, "%Y-%m-%d %H:%M:%S UTC", std::gmtime(&now));
  return "pid " + std::to_string(::getpid()) + " on host " + host + ", started " + when;
}

[[noreturn]] void refuse_held(const std::filesystem::path& dir, int fd) {
  char holder[512] = {};
  const ssize_t n = ::pread(fd, holder, sizeof holder - 1, 0);
  ::close(fd);
  // The holder writes its line just after taking the lock; caught in between, it is still unnamed.
  std::string who = n > 0 ? std::string(holder, static_cast<std::size_t>(n)) : "a process that has not named itself yet";
  while (!who.empty() && who.back() == '\n') who.pop_back();
  throw InputError(dir.string(), 0, "another vimd run is writing into this directory (" + who +
                                        "); refusing to run into it at the same time: choose another output directory, "
                                        "or wait until that run ends");
}

[[noreturn]] void lock_failed(const std::filesystem::path& file, const char* what, int fd) {
  const int error = errno;
  if (fd >= 0) ::close(fd);
  throw InputError(file.string(), 0, std::string("cannot ") + what + " the output directory's lock file: " +
                                         std::strerror(error));
}

}  // namespace

OutputLock::OutputLock(const std::filesystem::path& dir) : file_(dir / ".vimd.lock") {
  // The holder removes the file when it ends: a lock taken on a file removed meanwhile locks
  // nothing anyone else sees, so it is taken again on the file now there.
  for (;;) {
    fd_ = ::open(file_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) lock_failed(file_, "create", -1);
    if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      if (errno == EWOULDBLOCK) refuse_held(dir, fd_);
      lock_failed(file_, "lock", fd_);
    }
    struct stat locked, named;
    if (::fstat(fd_, &locked) != 0) lock_failed(file_, "inspect", fd_);
    if (::stat(file_.c_str(), &named) == 0 && named.st_ino == locked.st_ino && named.st_dev == locked.st_dev) break;
    ::close(fd_);
  }
  const std::string line = holder_text() + "\n";
  if (::ftruncate(fd_, 0) != 0) lock_failed(file_, "write", fd_);
  if (::pwrite(fd_, line.data(), line.size(), 0) != static_cast<ssize_t>(line.size())) {
    if (errno == 0) errno = ENOSPC;
    lock_failed(file_, "write", fd_);
  }
}

OutputLock::OutputLock(OutputLock&& other) noexcept : file_(std::move(other.file_)), fd_(other.fd_) { other.fd_ = -1; }

OutputLock::~OutputLock() {
  if (fd_ < 0) return;
  ::unlink(file_.c_str());  // while still locked: no other run can hold this file yet
  ::close(fd_);
}

}  // namespace vimd
