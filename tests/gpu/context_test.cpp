// Vulkan core: device choice, capabilities, suballocation, transfers round-trip, validation capture.
#include <gtest/gtest.h>

#include <cstring>
#include <numeric>

#include "gpu_test.h"
#include "mirage/gpu/commands.h"

using namespace mirage;
using namespace mirage::gpu;
using mirage::test::GpuTest;

class Gpu : public GpuTest {};

TEST_F(Gpu, DeviceHasWhatMirageNeeds) {
  const DeviceCapabilities& c = context().caps();
  EXPECT_FALSE(c.name.empty());
  EXPECT_GE(VK_API_VERSION_MINOR(c.apiVersion), 3u);
  EXPECT_GT(c.subgroupSize, 0u);
  EXPECT_TRUE(context().validationEnabled());
}

TEST_F(Gpu, EnumerateListsTheChosenDevice) {
  auto list = Context::enumerateDevices();
  ASSERT_TRUE(list.ok());
  ASSERT_FALSE(list->empty());
  bool found = false;
  for (const DeviceInfo& d : *list) found |= d.caps.name == context().caps().name;
  EXPECT_TRUE(found);
}

TEST_F(Gpu, BufferRoundTripThroughStaging) {
  std::vector<uint32_t> data(300000);
  std::iota(data.begin(), data.end(), 7u);
  Buffer b = createBufferWithData<uint32_t>(context(), data,
                                            VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "t");
  EXPECT_NE(b.address(), 0u);
  std::vector<uint8_t> back = readbackBuffer(context(), b, data.size() * 4);
  ASSERT_EQ(back.size(), data.size() * 4);
  EXPECT_EQ(std::memcmp(back.data(), data.data(), back.size()), 0);
}

TEST_F(Gpu, SuballocatorReusesFreedSpace) {
  Allocator& a = context().allocator();
  VkDeviceSize reservedBefore = a.bytesReserved();
  for (int round = 0; round < 3; ++round) {
    std::vector<Buffer> buffers;
    for (int i = 0; i < 64; ++i)
      buffers.push_back(
          createBuffer(context(), 256 * 1024, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::GpuOnly, "s"));
    // Distinct buffers never share device addresses ranges.
    for (size_t i = 1; i < buffers.size(); ++i) EXPECT_NE(buffers[i].address(), buffers[i - 1].address());
  }
  // Three rounds of 16 MiB fit in the same blocks: freeing coalesces, nothing grows per round.
  EXPECT_LE(a.bytesReserved(), reservedBefore + (64ull << 20));
}

TEST(GpuContext, UnknownDeviceIsAClearError) {
  ContextOptions o;
  o.device = "no-such-gpu-xyz";
  auto r = Context::create(o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("no-such-gpu-xyz"), std::string::npos);
}
