#pragma once
// Files a process writes before publishing them (an output before its atomic rename, a spool beside
// it): removed when the process is stopped by SIGINT, SIGTERM or SIGHUP first, so an interrupted
// `mirage build` (Ctrl-C, or mpirun ending a job whose rank failed) leaves nothing beside its
// output (a resumable write, `mirage build gen:many --resume`, registers nothing: its partial
// output stays for the next --resume, docs/bake.md). The handler is installed on first use for
// each of those signals whose disposition is still the default (a server's own clean-shutdown
// handler is left alone); it unlinks the registered paths (async-signal-safe: fixed buffers,
// unlink) and dies of the same signal.
#include <string>

namespace mirage {

// Registered for as long as it lives; release() (or destruction) once the file is renamed into
// place or removed. A path that does not fit the table (64 paths of up to 4095 bytes) is simply
// not removed on a signal.
class TempFileGuard {
public:
  TempFileGuard() = default;
  explicit TempFileGuard(const std::string& path);
  TempFileGuard(TempFileGuard&& other) noexcept : slot_(other.slot_) { other.slot_ = -1; }
  TempFileGuard& operator=(TempFileGuard&& other) noexcept;
  TempFileGuard(const TempFileGuard&) = delete;
  TempFileGuard& operator=(const TempFileGuard&) = delete;
  ~TempFileGuard() { release(); }
  void release();
  bool registered() const { return slot_ >= 0; }

private:
  int slot_ = -1;
};

} // namespace mirage
