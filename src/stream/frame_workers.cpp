// Frame workers (frame_workers.h).
#include "frame_workers.h"

#include <algorithm>

namespace mirage::stream {

uint32_t frameWorkerCount(uint32_t requested) {
  if (requested > 0) return requested;
  return std::clamp(std::thread::hardware_concurrency() / 4, 2u, 8u);
}

FrameWorkers::FrameWorkers(uint32_t threads) {
  for (uint32_t i = 0; i < std::max(threads, 1u); ++i) threads_.emplace_back([this] { loop(); });
}

FrameWorkers::~FrameWorkers() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  for (std::thread& t : threads_) t.join();
}

void FrameWorkers::push(std::function<void()> job) {
  {
    std::lock_guard lock(mutex_);
    jobs_.push_back(std::move(job));
  }
  wake_.notify_one();
}

void FrameWorkers::loop() {
  for (;;) {
    std::function<void()> job;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [&] { return stopping_ || !jobs_.empty(); });
      if (jobs_.empty()) return; // stopping, nothing left
      job = std::move(jobs_.front());
      jobs_.pop_front();
    }
    job();
  }
}

} // namespace mirage::stream
