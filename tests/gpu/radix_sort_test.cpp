// GPU radix sort against std::stable_sort: sizes around the block size (4096) and odd ones, 0 and
// 1, ascending and descending, all digits or some (stability shows in the unsorted bits), many
// equal digits; and the bitonic baseline against std::sort.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <functional>
#include <random>

#include "gpu_test.h"
#include "mirage/gpu/commands.h"
#include "mirage/gpu/radix_sort.h"

using namespace mirage;
using namespace mirage::gpu;
using mirage::test::GpuTest;

class RadixSortTest : public GpuTest {
protected:
  std::vector<uint64_t> sortOnGpu(const std::vector<uint64_t>& keys, const RadixSortOptions& options) {
    RadixSort sorter(context(), uint32_t(keys.size()));
    Buffer buffer = createBufferWithData<uint64_t>(
        context(), keys, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT, "keys");
    context().submitAndWait([&](VkCommandBuffer cmd) {
      sorter.cmdSort(cmd, buffer, uint32_t(keys.size()), options);
      cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                       VK_ACCESS_2_SHADER_WRITE_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
    });
    std::vector<uint64_t> out(keys.size());
    if (out.empty()) return out;
    std::vector<uint8_t> bytes = readbackBuffer(context(), buffer, out.size() * 8);
    std::memcpy(out.data(), bytes.data(), out.size() * 8);
    return out;
  }
};

namespace {

// What the GPU must produce: a stable sort on the selected digits only.
std::vector<uint64_t> expectedOrder(std::vector<uint64_t> keys, const RadixSortOptions& o) {
  uint64_t mask = 0;
  for (int d = 0; d < 8; ++d)
    if (o.digitMask >> d & 1u) mask |= uint64_t(0xFF) << (8 * d);
  std::stable_sort(keys.begin(), keys.end(), [&](uint64_t a, uint64_t b) {
    return o.descending ? (a & mask) > (b & mask) : (a & mask) < (b & mask);
  });
  return keys;
}

std::vector<uint64_t> randomKeys(size_t n, uint64_t seed, uint64_t valueMask = ~uint64_t(0)) {
  std::mt19937_64 rng(seed);
  std::vector<uint64_t> keys(n);
  for (uint64_t& k : keys) k = rng() & valueMask;
  return keys;
}

} // namespace

TEST_F(RadixSortTest, MatchesStableSortForManySizes) {
  for (size_t n : {0u, 1u, 2u, 3u, 255u, 256u, 257u, 4095u, 4096u, 4097u, 12345u}) {
    std::vector<uint64_t> keys = randomKeys(n, n + 1);
    for (bool descending : {false, true}) {
      RadixSortOptions o;
      o.descending = descending;
      EXPECT_EQ(sortOnGpu(keys, o), expectedOrder(keys, o)) << n << (descending ? " descending" : " ascending");
    }
  }
}

TEST_F(RadixSortTest, IsStableOnTheSortedDigits) {
  // Few distinct values in the sorted bytes, random unsorted bytes: a non-stable sort would mix them.
  std::vector<uint64_t> keys = randomKeys(20000, 7, 0x0300'0000'00FF'FFFFull);
  for (uint32_t mask : {0xF0u, 0x80u, 0x01u, 0x7u}) {
    for (bool descending : {false, true}) {
      RadixSortOptions o{descending, mask};
      EXPECT_EQ(sortOnGpu(keys, o), expectedOrder(keys, o)) << std::hex << mask << (descending ? " desc" : " asc");
    }
  }
}

TEST_F(RadixSortTest, SamplerKeysSortLikeTheBitonicBaseline) {
  // (non-negative float bits << 32 | index) with many equal radii and zeros (rejected candidates).
  std::mt19937 rng(3);
  std::vector<uint64_t> keys(5000);
  for (uint32_t i = 0; i < keys.size(); ++i) {
    float radius = float(rng() % 50) * 0.125f;
    uint32_t bits;
    std::memcpy(&bits, &radius, 4);
    keys[i] = rng() % 4 == 0 ? 0 : uint64_t(bits) << 32 | (rng() % 100000);
  }
  RadixSortOptions o{true, digitMaskForIndexBelow(100000)};
  EXPECT_EQ(o.digitMask, 0xF7u); // 17 bits of index: three low digits
  std::vector<uint64_t> sorted = sortOnGpu(keys, o);
  std::vector<uint64_t> expected = keys;
  std::sort(expected.begin(), expected.end(), std::greater<>());
  EXPECT_EQ(sorted, expected);

  // The bitonic baseline, padded with zeros to a power of two.
  std::vector<uint64_t> padded = keys;
  padded.resize(8192, 0);
  RadixSort sorter(context(), 8192);
  Buffer buffer = createBufferWithData<uint64_t>(
      context(), padded, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT, "keys");
  context().submitAndWait([&](VkCommandBuffer cmd) {
    sorter.cmdBitonicSort(cmd, buffer, 8192, true);
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
  });
  std::vector<uint8_t> bytes = readbackBuffer(context(), buffer, keys.size() * 8);
  std::vector<uint64_t> bitonic(keys.size());
  std::memcpy(bitonic.data(), bytes.data(), bytes.size());
  EXPECT_EQ(bitonic, expected);
}
