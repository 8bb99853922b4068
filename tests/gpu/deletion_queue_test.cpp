// gpu::DeletionQueue: a retired object lives until every slot that may use it completed.
#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/gpu/deletion_queue.h"

using namespace mirage;

class DeletionQueueTest : public test::GpuTest {};

TEST_F(DeletionQueueTest, FreesOnlyAfterEverySlotThatMayUseItCompleted) {
  gpu::Context& ctx = test::gpuContext();
  gpu::DeletionQueue q;
  auto buffer = [&] {
    return gpu::createBuffer(ctx, 64, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, gpu::MemoryUsage::GpuOnly, "t");
  };
  q.retire(buffer(), 0b101); // slots 0 and 2 may use it
  q.retire(buffer(), 0b010); // slot 1
  q.retire(buffer(), 0);     // nothing in flight: freed now
  EXPECT_EQ(q.pending(), 2u);
  q.completed(0);
  EXPECT_EQ(q.pending(), 2u); // slot 2 still may use the first
  q.completed(1);
  EXPECT_EQ(q.pending(), 1u);
  q.completed(2);
  EXPECT_EQ(q.pending(), 0u);
}
