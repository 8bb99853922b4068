// The GVS++ sampler's queue of sorted runs (src/visibility/run_queue.h) pops exactly what a binary
// heap of the same items pops, whatever mix of single pushes, sorted runs and pops.
#include <queue>
#include <random>

#include <gtest/gtest.h>

#include "../../src/visibility/run_queue.h"

namespace {

struct Item {
  float value;
  uint64_t order;
};
struct Lower {
  bool operator()(const Item& a, const Item& b) const {
    return a.value != b.value ? a.value < b.value : a.order > b.order;
  }
};

} // namespace

TEST(RunQueue, PopsWhatABinaryHeapPops) {
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> value(0, 40); // many ties: the order breaks them
  std::uniform_int_distribution<int> action(0, 9);
  mirage::vis::detail::RunQueue<Item, Lower> runs;
  std::priority_queue<Item, std::vector<Item>, Lower> heap;
  uint64_t order = 0;
  size_t popped = 0;
  for (int step = 0; step < 20000; ++step) {
    const int a = action(rng);
    if (a < 4) {
      Item it{float(value(rng)), order++};
      runs.push(it);
      heap.push(it);
    } else if (a < 5) { // a sorted run, as a staged chunk handed back
      std::vector<Item> run;
      for (int k = 0; k < 20; ++k) run.push_back({float(value(rng)), order++});
      std::sort(run.begin(), run.end(), [](const Item& x, const Item& y) { return Lower()(y, x); });
      for (const Item& it : run) heap.push(it);
      runs.pushRun(std::move(run));
    } else if (!heap.empty()) {
      ASSERT_FALSE(runs.empty());
      ASSERT_EQ(runs.top().order, heap.top().order) << "pop " << popped;
      runs.pop();
      heap.pop();
      ++popped;
    }
    ASSERT_EQ(runs.size(), heap.size());
  }
  EXPECT_GT(popped, 5000u);
}

// Long runs (a border chunk's seeds) whose values interleave with other runs', drained in large
// chunks and handed back, as the sampler stages them: still the binary heap's order.
TEST(RunQueue, LongRunsPopInHeapOrder) {
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> value(0, 400);
  mirage::vis::detail::RunQueue<Item, Lower> runs;
  std::priority_queue<Item, std::vector<Item>, Lower> heap;
  auto better = [](const Item& x, const Item& y) { return Lower()(y, x); };
  uint64_t order = 0;
  size_t popped = 0;
  for (int round = 0; round < 60; ++round) {
    std::vector<Item> run(1 + rng() % 3000);
    for (Item& it : run) it = {float(value(rng)), order++};
    std::sort(run.begin(), run.end(), better);
    for (const Item& it : run) heap.push(it);
    runs.pushRun(std::move(run));
    for (int k = 0; k < 50; ++k) { // single pushes among the runs
      Item it{float(value(rng)), order++};
      runs.push(it);
      heap.push(it);
    }
    std::vector<Item> chunk; // a chunk taken off and handed back
    for (size_t k = rng() % 4000; k > 0 && !heap.empty(); --k) {
      ASSERT_EQ(runs.top().order, heap.top().order) << "pop " << popped;
      chunk.push_back(runs.top());
      runs.pop();
      heap.pop();
      ++popped;
    }
    if (round % 3 == 0) {
      for (const Item& it : chunk) heap.push(it);
      runs.pushRun(std::move(chunk));
    }
    ASSERT_EQ(runs.size(), heap.size());
  }
  while (!heap.empty()) {
    ASSERT_EQ(runs.top().order, heap.top().order) << "pop " << popped;
    runs.pop();
    heap.pop();
    ++popped;
  }
  EXPECT_TRUE(runs.empty());
  EXPECT_GT(popped, 50000u);
}
