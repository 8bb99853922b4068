#pragma once
// Threads that finish client frames (ClientStream::finishFrame: the atlas encode and the patch
// section) while the one thread that drives the GPU prepares the next client's frame
// (docs/stream.md, "Server"). The server loop and `bench stream` use them alike.
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <thread>
#include <type_traits>
#include <vector>

namespace mirage::stream {

// Workers for `requested` (0: a quarter of the processors, at least 2 so one frame encodes while the
// next is prepared, at most 8). Each H.264 encoder runs its own slice threads besides; a few
// encoders at once also fill the processors during each frame's serial parts (x264's picture copy
// and lookahead analysis, the patch section).
uint32_t frameWorkerCount(uint32_t requested);

class FrameWorkers {
public:
  explicit FrameWorkers(uint32_t threads);
  ~FrameWorkers(); // runs the jobs queued, then joins
  FrameWorkers(const FrameWorkers&) = delete;
  FrameWorkers& operator=(const FrameWorkers&) = delete;

  // Runs `job` on a worker, jobs in the order given; the future holds its result.
  template <class F> std::future<std::invoke_result_t<F>> submit(F job) {
    auto task = std::make_shared<std::packaged_task<std::invoke_result_t<F>()>>(std::move(job));
    auto future = task->get_future();
    push([task] { (*task)(); });
    return future;
  }

private:
  void push(std::function<void()> job);
  void loop();

  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::function<void()>> jobs_;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

} // namespace mirage::stream
