#pragma once
// One run per output directory: a run holds an exclusive flock on DIR/.vimd.lock for its lifetime,
// the file naming the holder (pid, host, start time), and removes the file when it ends. The kernel
// releases the lock when the process ends however it ends (kill -9 included): a file left behind
// then is not a lock, and the next run takes it over.
#include <filesystem>

namespace vimd {

class OutputLock {
 public:
  // InputError naming the directory and the holder when another process holds it, or naming the
  // lock file and the system's reason when it cannot be created.
  explicit OutputLock(const std::filesystem::path& dir);
  ~OutputLock();
  OutputLock(OutputLock&& other) noexcept;
  OutputLock(const OutputLock&) = delete;
  OutputLock& operator=(const OutputLock&) = delete;
  OutputLock& operator=(OutputLock&&) = delete;

 private:
  std::filesystem::path file_;
  int fd_;
};

}  // namespace vimd
