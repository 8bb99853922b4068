// PVS storage: round trips (full and difference cells), compactness, corrupt input rejected.
#include <random>

#include <gtest/gtest.h>

#include "mirage/visibility/pvs_storage.h"
#include "test_support.h"

using namespace mirage;
using namespace mirage::vis;

namespace {

PvsData sampleData() {
  PvsData d;
  d.sceneTriangles = 1'000'000;
  std::mt19937 rng(3);
  std::vector<uint32_t> base;
  for (uint32_t i = 0; i < 1'000'000; i += 1 + rng() % 40) base.push_back(i);
  for (int c = 0; c < 6; ++c) {
    ViewCell cell;
    cell.position = {float(c) * 4.0f, 1.7f, 0.0f};
    cell.size = {4, 2, 4};
    d.cells.push_back(cell);
    // Neighbours share most triangles: drop and add a few percent each.
    std::vector<uint32_t> ids;
    for (uint32_t id : base)
      if (rng() % 100 >= 3) ids.push_back(id);
    for (int k = 0; k < 500; ++k) ids.push_back(rng() % 1'000'000);
    std::sort(ids.begin(), ids.end());
    ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
    d.triangles.push_back(ids);
  }
  d.triangles.push_back({}); // an empty PVS is legal
  d.cells.push_back(d.cells[0]);
  return d;
}

} // namespace

TEST(PvsStorage, RoundTripWithDifferences) {
  PvsData d = sampleData();
  PvsEncodeStats stats;
  auto bytes = encodePvs(d, {}, &stats);
  EXPECT_GT(stats.differenceCells, 0u);
  auto back = decodePvs(bytes, "mem");
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->triangles, d.triangles);
  EXPECT_EQ(back->cells.size(), d.cells.size());
  EXPECT_EQ(back->cells[3].position, d.cells[3].position);
  // Differences must beat storing every cell in full.
  PvsEncodeStats fullStats;
  encodePvs(d, {.differences = false}, &fullStats);
  EXPECT_LT(stats.totalBytes, fullStats.totalBytes * 2 / 3);
  // ~40k IDs with mean gap ~20 need ≥ 5 bits each raw; delta+varint+zstd stays under 2.5 bytes.
  EXPECT_LT(double(fullStats.cellBytes[0]) / double(d.triangles[0].size()), 2.5);
}

TEST(PvsStorage, FileRoundTrip) {
  PvsData d = sampleData();
  auto path = (test::tempDir("pvs") / "p.mrg").string();
  ASSERT_TRUE(savePvs(path, d, "gen:test").ok());
  auto back = loadPvs(path);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->triangles, d.triangles);
}

TEST(PvsStorage, RejectsCorruptPayloads) {
  PvsData d = sampleData();
  auto bytes = encodePvs(d);
  std::mt19937 rng(5);
  // Truncations and single-byte flips: every result is an error or a valid decode, never a crash.
  for (size_t cut : {size_t(0), size_t(3), size_t(20), bytes.size() / 2, bytes.size() - 1})
    EXPECT_FALSE(decodePvs(std::span(bytes.data(), cut), "mem").ok());
  for (int i = 0; i < 300; ++i) {
    auto bad = bytes;
    bad[rng() % bad.size()] ^= uint8_t(1 + rng() % 255);
    auto r = decodePvs(bad, "mem");
    if (!r.ok()) {
      EXPECT_EQ(r.error().message.rfind("mem: ", 0), 0u) << r.error().message;
    }
  }
  PvsData outOfRange = d;
  outOfRange.sceneTriangles = 10;
  EXPECT_FALSE(decodePvs(encodePvs(outOfRange), "mem").ok());
}
