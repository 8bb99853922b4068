#pragma once
// A priority queue made of sorted runs (private to the GVS++ sampler, gvs.cpp): items pushed one by
// one collect in an unsorted run that is sorted when the queue is next read; a run already in
// priority order (a chunk handed back, the discontinuities of a border chunk) goes in as it is. The
// top is the best head of the runs (a heap over runs). It pops exactly what one binary heap of all
// items would, given a strict order, at a fraction of the cost: the sampler queues millions of
// seeds and puts every staged chunk back before taking the next, which in a binary heap of
// 32-byte items was most of its host time once the rays were made on the GPU.
#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

namespace mirage::vis::detail {

// `Lower(a, b)`: a comes after b (a strict total order, as for std::priority_queue).
template <class T, class Lower> class RunQueue {
public:
  bool empty() const { return size_ == 0; }
  size_t size() const { return size_; }
  void push(T item) {
    unsorted_.push_back(std::move(item));
    ++size_;
  }
  // Items already in priority order (first = best).
  void pushRun(std::vector<T>&& run) {
    if (run.empty()) return;
    size_ += run.size();
    addRun(std::move(run));
  }
  const T& top() {
    seal();
    const Run& r = runs_[heap_.front()];
    return r.items[r.head];
  }
  void pop() {
    seal();
    Run& r = runs_[heap_.front()];
    --size_;
    if (++r.head == r.items.size()) {
      std::vector<T>().swap(r.items); // release the exhausted run
      free_.push_back(heap_.front());
      heap_.front() = heap_.back();
      heap_.pop_back();
    }
    // Only the top run's head changed: one sift down, which ends at once while that run still
    // leads (a chunk taken off one run costs two comparisons an item, not two heap updates).
    siftDown();
  }

private:
  struct Run {
    std::vector<T> items;
    size_t head = 0;
  };
  auto heapOrder() {
    return [this](uint32_t a, uint32_t b) {
      return Lower()(runs_[a].items[runs_[a].head], runs_[b].items[runs_[b].head]);
    };
  }
  void addRun(std::vector<T>&& items) {
    uint32_t index;
    if (free_.empty()) {
      index = uint32_t(runs_.size());
      runs_.emplace_back();
    } else {
      index = free_.back();
      free_.pop_back();
    }
    runs_[index] = {std::move(items), 0};
    heap_.push_back(index);
    std::push_heap(heap_.begin(), heap_.end(), heapOrder());
  }
  // Restores the heap order (std::push_heap's: no parent ranks below a child) from the root down.
  void siftDown() {
    auto lower = heapOrder();
    const size_t n = heap_.size();
    for (size_t i = 0;;) {
      size_t child = 2 * i + 1;
      if (child >= n) return;
      if (child + 1 < n && lower(heap_[child], heap_[child + 1])) ++child;
      if (!lower(heap_[i], heap_[child])) return;
      std::swap(heap_[i], heap_[child]);
      i = child;
    }
  }
  void seal() {
    if (unsorted_.empty()) return;
    auto better = [](const T& a, const T& b) { return Lower()(b, a); };
    if (!std::is_sorted(unsorted_.begin(), unsorted_.end(), better))
      std::sort(unsorted_.begin(), unsorted_.end(), better);
    addRun(std::exchange(unsorted_, {}));
  }

  std::vector<Run> runs_;
  std::vector<uint32_t> heap_; // indices of the non-empty runs, best head on top
  std::vector<uint32_t> free_; // indices of released runs
  std::vector<T> unsorted_;
  size_t size_ = 0;
};

} // namespace mirage::vis::detail
