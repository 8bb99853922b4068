// DenseIdMap against std::map under random inserts, lookups and erases (also while walking).
#include <map>
#include <random>

#include <gtest/gtest.h>

#include "mirage/core/dense_id_map.h"

namespace mirage {
namespace {

void expectSame(const DenseIdMap<int>& dense, const std::map<uint32_t, int>& reference) {
  ASSERT_EQ(dense.size(), reference.size());
  std::map<uint32_t, int> walked;
  for (const auto& [id, value] : dense) EXPECT_TRUE(walked.emplace(id, value).second) << "id " << id << " twice";
  EXPECT_EQ(walked, reference);
  for (const auto& [id, value] : reference) {
    const int* found = dense.find(id);
    ASSERT_NE(found, nullptr) << id;
    EXPECT_EQ(*found, value);
  }
}

TEST(DenseIdMap, MatchesAnOrderedMap) {
  std::mt19937 rng(3);
  DenseIdMap<int> dense;
  std::map<uint32_t, int> reference;
  for (int step = 0; step < 20000; ++step) {
    uint32_t id = rng() % 3000;
    switch (rng() % 4) {
    case 0:
    case 1:
      dense[id] = step;
      reference[id] = step;
      break;
    case 2:
      EXPECT_EQ(dense.erase(id), reference.erase(id) == 1);
      break;
    default:
      EXPECT_EQ(dense.contains(id), reference.count(id) == 1);
      EXPECT_EQ(dense.find(id) == nullptr, reference.count(id) == 0);
    }
    if (step % 997 == 0) expectSame(dense, reference);
  }
  expectSame(dense, reference);
  // Erasing while walking backwards visits every entry once.
  auto& entries = dense.entries();
  for (size_t i = entries.size(); i-- > 0;) {
    if (entries[i].second % 3 == 0) {
      reference.erase(entries[i].first);
      dense.eraseAt(i);
    }
  }
  expectSame(dense, reference);
  dense.clear();
  reference.clear();
  expectSame(dense, reference);
  EXPECT_FALSE(dense.contains(5));
  dense[5] = 1;
  EXPECT_EQ(*dense.find(5), 1);
  EXPECT_EQ(dense[7], 0) << "absent: default";
}

} // namespace
} // namespace mirage
