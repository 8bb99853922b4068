#include "mirage/core/progress.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#include <unistd.h>

namespace mirage {

namespace {

// The reporter whose terminal line is on screen without its newline (one stderr, so one line).
std::atomic<Progress*> g_terminalLine{nullptr};

// Seconds for humans: "0.4 s", "12.3 s", "4 min 05 s", "1 h 02 min".
std::string formatSeconds(double s) {
  char buf[48];
  if (!std::isfinite(s) || s < 0.0) s = 0.0;
  if (s < 60.0) {
    std::snprintf(buf, sizeof buf, "%.1f s", s);
  } else if (s < 3600.0) {
    auto t = uint64_t(s);
    std::snprintf(buf, sizeof buf, "%u min %02u s", unsigned(t / 60), unsigned(t % 60));
  } else {
    auto t = uint64_t(s / 60.0);
    std::snprintf(buf, sizeof buf, "%llu h %02u min", (unsigned long long)(t / 60), unsigned(t % 60));
  }
  return buf;
}

std::string times(uint64_t done, uint64_t total, double elapsed) {
  std::string s = formatSeconds(elapsed);
  // The ETA extrapolates the mean rate so far: honest for the uniform units every caller reports.
  if (total > 0 && done > 0 && done < total)
    s += ", ETA " + formatSeconds(elapsed * double(total - done) / double(done));
  return s;
}

} // namespace

ProgressMode progressMode(bool quiet, bool lines) {
  if (quiet) return ProgressMode::None;
  if (lines) return ProgressMode::Lines;
  return isatty(STDERR_FILENO) ? ProgressMode::Terminal : ProgressMode::None;
}

std::string formatProgress(ProgressMode mode, std::string_view label, uint64_t done, uint64_t total,
                           double elapsedSeconds, std::string_view detail) {
  std::string s(label);
  double fraction = total ? std::min(1.0, double(done) / double(total)) : 0.0;
  char buf[96];
  if (mode == ProgressMode::Terminal) {
    if (total) {
      constexpr int width = 24;
      int filled = int(fraction * width);
      s += " [" + std::string(size_t(filled), '#') + std::string(size_t(width - filled), ' ') + "]";
      std::snprintf(buf, sizeof buf, " %3d%%  %llu/%llu  ", int(fraction * 100.0), (unsigned long long)done,
                    (unsigned long long)total);
    } else {
      std::snprintf(buf, sizeof buf, "  %llu  ", (unsigned long long)done);
    }
    s += buf + times(done, total, elapsedSeconds);
    if (!detail.empty()) s += "  " + std::string(detail);
    return s;
  }
  if (total)
    std::snprintf(buf, sizeof buf, ": %llu/%llu (%d%%), ", (unsigned long long)done, (unsigned long long)total,
                  int(fraction * 100.0));
  else
    std::snprintf(buf, sizeof buf, ": %llu, ", (unsigned long long)done);
  s += buf + times(done, total, elapsedSeconds);
  if (!detail.empty()) s += ": " + std::string(detail);
  return s;
}

std::string formatProgressEnd(std::string_view label, uint64_t done, uint64_t total, double elapsedSeconds,
                              std::string_view detail) {
  char buf[64];
  if (total)
    std::snprintf(buf, sizeof buf, ": done %llu/%llu in ", (unsigned long long)done, (unsigned long long)total);
  else
    std::snprintf(buf, sizeof buf, ": done %llu in ", (unsigned long long)done);
  std::string s = std::string(label) + buf + formatSeconds(elapsedSeconds);
  if (!detail.empty()) s += ": " + std::string(detail);
  return s;
}

Progress::Progress(ProgressMode mode, std::FILE* out)
    : intervalSeconds(mode == ProgressMode::Lines ? 1.0 : 0.1), mode_(mode), out_(out) {}

Progress::~Progress() {
  std::lock_guard lock(mutex_);
  // An unfinished terminal line (the work stopped early) ends so later output starts on a fresh line.
  if (lineShown_) std::fputc('\n', out_);
  releaseLine();
}

void Progress::releaseLine() {
  lineShown_ = false;
  Progress* self = this;
  g_terminalLine.compare_exchange_strong(self, nullptr);
}

void Progress::breakLine() {
  Progress* p = g_terminalLine.exchange(nullptr);
  if (!p) return;
  std::lock_guard lock(p->mutex_);
  if (!p->lineShown_) return;
  std::fputc('\n', p->out_);
  std::fflush(p->out_);
  p->lineShown_ = false;
  p->lastWidth_ = 0;
}

// The terminal line shows the last unit at once; log lines leave it to end()'s line.
bool Progress::finished() const { return mode_ == ProgressMode::Terminal && total_ && done_ >= total_; }

double Progress::elapsed() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void Progress::begin(std::string_view label, uint64_t total) {
  if (mode_ == ProgressMode::None) return;
  end();
  std::lock_guard lock(mutex_);
  label_ = label;
  done_ = 0;
  total_ = total;
  open_ = true;
  printed_ = false;
  lastWidth_ = 0;
  start_ = std::chrono::steady_clock::now();
  print(true, {});
}

void Progress::advance(uint64_t n, std::string_view detail) {
  if (mode_ == ProgressMode::None) return;
  std::lock_guard lock(mutex_);
  if (!open_) return;
  done_ += n;
  print(finished(), detail);
}

void Progress::update(uint64_t done, uint64_t total, std::string_view detail) {
  if (mode_ == ProgressMode::None) return;
  std::lock_guard lock(mutex_);
  if (!open_) return;
  done_ = std::max(done_, done);
  if (total) total_ = total;
  print(finished(), detail);
}

void Progress::end(std::string_view detail) {
  if (mode_ == ProgressMode::None) return;
  std::lock_guard lock(mutex_);
  if (!open_) return;
  open_ = false;
  std::string line = formatProgressEnd(label_, done_, total_, elapsed(), detail);
  if (mode_ == ProgressMode::Terminal) {
    size_t pad = lastWidth_ > line.size() ? lastWidth_ - line.size() : 0;
    std::fprintf(out_, "\r%s%*s\n", line.c_str(), int(pad), "");
    releaseLine();
  } else {
    std::fprintf(out_, "%s\n", line.c_str());
  }
  std::fflush(out_);
}

ProgressCallback Progress::callback() {
  return [this](uint64_t done, uint64_t total, std::string_view detail) { update(done, total, detail); };
}

void Progress::print(bool force, std::string_view detail) {
  auto now = std::chrono::steady_clock::now();
  if (!force && printed_ && std::chrono::duration<double>(now - lastPrint_).count() < intervalSeconds) return;
  printed_ = true;
  lastPrint_ = now;
  std::string line = formatProgress(mode_, label_, done_, total_, elapsed(), detail);
  if (mode_ == ProgressMode::Terminal) {
    // Blank what a longer previous line left behind (no terminal escape codes: works everywhere).
    size_t pad = lastWidth_ > line.size() ? lastWidth_ - line.size() : 0;
    std::fprintf(out_, "\r%s%*s", line.c_str(), int(pad), "");
    lastWidth_ = line.size();
    lineShown_ = true;
    g_terminalLine.store(this);
  } else {
    std::fprintf(out_, "%s\n", line.c_str());
  }
  std::fflush(out_);
}

} // namespace mirage
