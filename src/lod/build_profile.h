#pragma once
// Build profiling: per-stage thread CPU time and per-phase wall time of buildClusterDag, printed to
// stderr when MIRAGE_LOD_PROFILE is set (docs/lod.md, "How to measure").
#include <atomic>
#include <chrono>
#include <cstdint>
#include <ctime>

namespace mirage::lod::detail {

// Per-stage CPU time summed over threads (CLOCK_THREAD_CPUTIME_ID: other processes on a shared
// machine do not inflate it), printed to stderr when MIRAGE_LOD_PROFILE is set: the numbers in
// docs/lod.md's "where the time goes" come from here (no public API for it). Stages marked
// serial run on one thread whatever --threads says; the others are parallel, and a stage timed
// around a parallel loop counts only the calling thread, so profile those with --threads 1.
enum Stage {
  kPrep,
  kLevel0,
  kLevel0Append,
  kBorders,
  kPartition,
  kMetis,
  kOwners,
  kGather,
  kSimplify,
  kSplit,
  kCommit,
  kSourceMap,
  kStageCount
};
extern std::atomic<int64_t> gStageNs[kStageCount];

inline int64_t threadCpuNs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return int64_t(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

class StageTimer {
public:
  explicit StageTimer(Stage s) : stage_(s), start_(threadCpuNs()) {}
  ~StageTimer() { gStageNs[stage_] += threadCpuNs() - start_; }
  StageTimer(const StageTimer&) = delete;
  StageTimer& operator=(const StageTimer&) = delete;

private:
  Stage stage_;
  int64_t start_;
};

// Wall-clock seconds of the build's phases (main thread) and the process CPU seconds spent in
// them (all threads), beside the CPU stages: where a parallel build waits on serial work.
enum WallPhase { kWallPrep, kWallLevel0, kWallGrouping, kWallSimplify, kWallCommit, kWallCount };
extern std::atomic<double> gWallSeconds[kWallCount], gWallCpuSeconds[kWallCount]; // builds may run concurrently

inline double processCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + double(ts.tv_nsec) * 1e-9;
}

class WallTimer {
public:
  explicit WallTimer(WallPhase p) : phase_(p), start_(std::chrono::steady_clock::now()), cpu_(processCpuSeconds()) {}
  ~WallTimer() {
    gWallSeconds[phase_].fetch_add(std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count());
    gWallCpuSeconds[phase_].fetch_add(processCpuSeconds() - cpu_);
  }
  WallTimer(const WallTimer&) = delete;
  WallTimer& operator=(const WallTimer&) = delete;

private:
  WallPhase phase_;
  std::chrono::steady_clock::time_point start_;
  double cpu_;
};

// Prints (and resets) the sums when MIRAGE_LOD_PROFILE is set; resets them otherwise.
void printStages(uint64_t triangles);

} // namespace mirage::lod::detail
