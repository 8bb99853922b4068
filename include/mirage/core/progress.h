#pragma once
// Progress of long work (verify, pvs, pvs-eval, surfels, build), one reporter for every command.
// Libraries take a plain ProgressCallback and never print; the CLI owns a Progress that turns the
// callback's calls into output on stderr:
//   - Terminal: one self-updating line (bar, done/total, elapsed, ETA, detail).
//   - Lines:    plain lines for logs (`--progress`), throttled, always the first and the last.
//   - None:     nothing (`--quiet`, or stderr is not a terminal and `--progress` was not given).
// Usage:
//   Progress p(progressMode(quiet, progressFlag));
//   p.begin("verify", totalCuts);
//   for (...) { ...; p.advance(1, "mesh 3 cut 17"); }
//   p.end();
// or hand a library `p.callback()` (after begin) where it takes a ProgressCallback.
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <mutex>
#include <string>
#include <string_view>

namespace mirage {

// What a library reports: `done` of `total` units of work (total 0: unknown), with a short
// one-line detail (e.g. "cell 3/8: 1.2 M rays, 4,310 triangles found"). May be called from any
// thread; calls need not be monotonic in time order but `done` should not decrease.
using ProgressCallback = std::function<void(uint64_t done, uint64_t total, std::string_view detail)>;

enum class ProgressMode { None, Terminal, Lines };

// quiet wins; then lines (--progress) ; then a terminal line when stderr is a terminal; else none.
ProgressMode progressMode(bool quiet, bool lines);

// One report as text, without the leading '\r' or trailing newline (pure, for tests and the reporter).
// Terminal: "verify [########            ]  40%  40/100  1.2 s, ETA 1.8 s  mesh 0 cut 39"
// Lines:    "verify: 40/100 (40%), 1.2 s, ETA 1.8 s: mesh 0 cut 39"
// total 0 leaves out the bar, percentage and ETA.
std::string formatProgress(ProgressMode mode, std::string_view label, uint64_t done, uint64_t total,
                           double elapsedSeconds, std::string_view detail);

// The last line of a finished task: "verify: done 100/100 in 3.0 s" (detail appended after ": ").
std::string formatProgressEnd(std::string_view label, uint64_t done, uint64_t total, double elapsedSeconds,
                              std::string_view detail);

// Thread-safe reporter writing to `out` (stderr by default). Mode None makes every call a no-op.
class Progress {
public:
  explicit Progress(ProgressMode mode = ProgressMode::None, std::FILE* out = stderr);
  ~Progress(); // ends an unfinished task's terminal line so errors start on a fresh line
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  // Starts a task (ends the previous one if still open). total 0: unknown.
  void begin(std::string_view label, uint64_t total);
  // n more units done.
  void advance(uint64_t n = 1, std::string_view detail = {});
  // Absolute position (and total, when a library learns it late); the ProgressCallback form.
  void update(uint64_t done, uint64_t total, std::string_view detail = {});
  // Prints the end line (Lines) or finishes the terminal line; a no-op when no task is open.
  void end(std::string_view detail = {});
  // A callback for libraries forwarding to update(); valid while this Progress lives.
  ProgressCallback callback();

  ProgressMode mode() const { return mode_; }
  // Ends the terminal line on screen (if any) with a newline, so that a message printed next (an
  // error) starts on a fresh line; that reporter's next update starts a new line. Call it from the
  // thread that owns the reporter, before printing to stderr.
  static void breakLine();
  // Minimum seconds between two printed updates (first and last always print); 0 prints all.
  double intervalSeconds;

private:
  void print(bool force, std::string_view detail);
  double elapsed() const;
  void releaseLine(); // mutex_ held
  bool finished() const;

  ProgressMode mode_;
  std::FILE* out_;
  std::mutex mutex_;
  std::string label_;
  uint64_t done_ = 0, total_ = 0;
  bool open_ = false;
  std::chrono::steady_clock::time_point start_{}, lastPrint_{};
  bool printed_ = false;
  size_t lastWidth_ = 0;   // terminal: characters of the previous line, to blank what is left of it
  bool lineShown_ = false; // terminal: a line without its newline is on screen
};

} // namespace mirage
