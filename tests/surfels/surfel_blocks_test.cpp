// The progressive 'SURF' chunk (CPU only): block sizes, every byte prefix decoding to exactly the
// surfels of its complete blocks (a prefix of the cloud, blue noise by the normalized Poisson radius
// ρ), byte flips rejected naming file, chunk and block, numbers checked behind valid checksums, and
// a file written before blocks (container version 1, flat SURF version 2) still loading.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>

#include "mirage/asset/blocks.h"
#include "mirage/asset/container.h"
#include "mirage/surfels/reference.h"
#include "mirage/surfels/surfel_io.h"
#include "test_support.h"

using namespace mirage;
using namespace mirage::surfels;

namespace {

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// A jittered 150 x 150 grid on the unit square: texels for the exact farthest-point order.
const GBufferTexels& squareTexels() {
  static const GBufferTexels t = [] {
    GBufferTexels g;
    const uint32_t n = 150;
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> jitter(-0.3f, 0.3f);
    g.center = {0.5f, 0.5f, 0.0f};
    g.sphereRadius = 0.75f;
    for (uint32_t i = 0; i < n * n; ++i) {
      g.ids.push_back(i);
      g.positions.push_back({(float(i % n) + 0.5f + jitter(rng)) / n, (float(i / n) + 0.5f + jitter(rng)) / n, 0.0f});
      g.normals.push_back({0, 0, 1});
      g.colors.push_back(0xff000000u | i);
      g.areas.push_back(1.0f / float(n * n));
    }
    g.totalArea = 1.0;
    return g;
  }();
  return t;
}

const SampleOrder& blueOrder() {
  static const SampleOrder o = farthestPointReference(squareTexels(), 4000);
  return o;
}

const SurfelCloud& blueCloud() {
  static const SurfelCloud c = buildSurfelCloud(squareTexels(), blueOrder());
  return c;
}

const SurfelBlockConfig kSmallBlocks{256, 1024, 3}; // ends 256, 512, 1024, 2048, 3072, 4000

bool samePrefix(const SurfelCloud& prefix, const SurfelCloud& whole) {
  // memcmp of empty vectors may get null pointers, which it must not.
  if (prefix.size() > whole.size() || prefix.radii.size() != prefix.size()) return false;
  return prefix.size() == 0 ||
         (std::memcmp(prefix.surfels.data(), whole.surfels.data(), prefix.size() * sizeof(Surfel)) == 0 &&
          std::memcmp(prefix.radii.data(), whole.radii.data(), prefix.size() * sizeof(float)) == 0);
}

// ρ = r_min / r_max of decoded surfels: half the smallest pairwise distance over the radius of N
// discs in hexagonal packing on area A (reference.h), from the dequantized positions.
double decodedRho(const SurfelCloud& c, double area) {
  std::vector<glm::vec3> p;
  for (const Surfel& s : c.surfels) p.push_back(surfelPosition(c.box, s));
  float best = std::numeric_limits<float>::max();
  for (size_t i = 0; i < p.size(); ++i)
    for (size_t j = i + 1; j < p.size(); ++j) best = std::min(best, glm::dot(p[i] - p[j], p[i] - p[j]));
  double rMin = 0.5 * std::sqrt(double(best));
  double rMax = std::sqrt(area / (2.0 * std::sqrt(3.0) * double(p.size())));
  return rMin / rMax;
}

// The payload of the single SURF chunk of a file, and where it starts in the file.
std::pair<std::vector<uint8_t>, uint64_t> surfPayload(const std::string& path) {
  auto r = asset::AssetReader::open(path);
  EXPECT_TRUE(r.ok()) << r.error().message;
  auto bytes = r->readChunk(0);
  EXPECT_TRUE(bytes.ok()) << bytes.error().message;
  return {*bytes, r->chunks()[0].offset};
}

} // namespace

TEST(SurfelBlocks, BlockSizesDoubleThenStayAndConfigsAreChecked) {
  SurfelBlockConfig d;
  EXPECT_EQ(surfelBlockEnds(100000, d),
            (std::vector<uint32_t>{1024, 2048, 4096, 8192, 16384, 32768, 49152, 65536, 81920, 98304, 100000}));
  EXPECT_TRUE(surfelBlockEnds(0, d).empty());
  EXPECT_EQ(surfelBlockEnds(10, d), (std::vector<uint32_t>{10}));
  EXPECT_EQ(surfelBlockEnds(1025, d), (std::vector<uint32_t>{1024, 1025}));
  EXPECT_EQ(surfelBlockEnds(4000, kSmallBlocks), (std::vector<uint32_t>{256, 512, 1024, 2048, 3072, 4000}));
  // Block ends are ends of the renderer's coherent blocks (size max(256, 2^⌊log2 i⌋ / 16) at
  // position i, docs/surfels.md) up to 16 × maxSurfels surfels: a streamed prefix draws whole.
  for (uint32_t end : surfelBlockEnds(1u << 20, d)) {
    if (end >= 16 * d.maxSurfels) break;
    uint32_t coherent = std::max(256u, std::bit_floor(end - 1) / 16);
    EXPECT_EQ(end % coherent, 0u) << end;
  }
  for (SurfelBlockConfig bad : {SurfelBlockConfig{1000, 16384}, SurfelBlockConfig{4096, 1024},
                                SurfelBlockConfig{128, 1024}, SurfelBlockConfig{1024, 1u << 21}}) {
    EXPECT_FALSE(checkSurfelBlockConfig(bad).ok()) << bad.firstSurfels << ":" << bad.maxSurfels;
    EXPECT_FALSE(encodeSurfelChunk(blueCloud(), kWholeScene, bad).ok());
  }
  auto parsed = parseSurfelBlockConfig("512:8192");
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  EXPECT_EQ(parsed->firstSurfels, 512u);
  EXPECT_EQ(parsed->maxSurfels, 8192u);
  for (const char* bad : {"1024", "a:b", "1024:16384x", ":1024", "1024:", "-256:1024", "1000:16384"})
    EXPECT_FALSE(parseSurfelBlockConfig(bad).ok()) << bad;
}

TEST(SurfelBlocks, EveryBytePrefixDecodesToABlueNoisePrefix) {
  const SurfelCloud& cloud = blueCloud();
  ASSERT_EQ(cloud.size(), 4000u);
  auto payload = encodeSurfelChunk(cloud, 7, kSmallBlocks);
  ASSERT_TRUE(payload.ok()) << payload.error().message;
  auto table = asset::decodeBlockTable(*payload, "p");
  ASSERT_TRUE(table.ok()) << table.error().message;
  std::vector<uint32_t> ends = surfelBlockEnds(4000, kSmallBlocks);
  ASSERT_EQ(table->blocks.size(), ends.size());
  // Prefix lengths: every one up to the index and around each block's end, every 13th between.
  std::vector<size_t> lengths;
  for (size_t n = 0; n <= payload->size(); ++n) {
    bool nearEnd = n <= table->indexBytes + 2;
    for (const asset::BlockInfo& b : table->blocks)
      nearEnd = nearEnd || (n + 2 >= b.offset + b.storedBytes && n <= b.offset + b.storedBytes + 2);
    if (nearEnd || n % 13 == 0 || n == payload->size()) lengths.push_back(n);
  }
  std::vector<uint32_t> seenCounts;
  for (size_t n : lengths) {
    auto p = decodeSurfelPrefix(std::span(*payload).first(n), "p.mrg");
    ASSERT_TRUE(p.ok()) << n << ": " << p.error().message;
    size_t complete = 0;
    while (n >= table->indexBytes && complete < ends.size() &&
           table->blocks[complete].offset + table->blocks[complete].storedBytes <= n)
      ++complete;
    uint32_t expected = complete ? ends[complete - 1] : 0;
    const SurfelCloud& c = p->surfels.cloud;
    ASSERT_EQ(c.size(), expected) << n;
    ASSERT_TRUE(samePrefix(c, cloud)) << n;
    EXPECT_EQ(p->haveIndex, n >= table->indexBytes) << n;
    EXPECT_EQ(p->complete(), n == payload->size()) << n;
    if (p->haveIndex) {
      EXPECT_EQ(p->total, 4000u);
      EXPECT_EQ(p->surfels.mesh, 7u);
      EXPECT_EQ(c.box.min, cloud.box.min);
      EXPECT_EQ(c.box.max, cloud.box.max);
      EXPECT_EQ(c.referenceMeanSpacing, cloud.referenceMeanSpacing);
    }
    if (seenCounts.empty() || seenCounts.back() != c.size()) seenCounts.push_back(uint32_t(c.size()));
  }
  // Every block end was reached, and each decoded prefix is blue noise (the reference test's bound).
  std::vector<uint32_t> expectedCounts = {0};
  expectedCounts.insert(expectedCounts.end(), ends.begin(), ends.end());
  EXPECT_EQ(seenCounts, expectedCounts);
  for (size_t b = 0; b < ends.size(); ++b) {
    uint32_t k = ends[b];
    auto p = decodeSurfelPrefix(
        std::span(*payload).first(size_t(table->blocks[b].offset + table->blocks[b].storedBytes)), "p.mrg");
    ASSERT_TRUE(p.ok());
    ASSERT_EQ(p->surfels.cloud.size(), k);
    double rho = decodedRho(p->surfels.cloud, squareTexels().totalArea);
    EXPECT_GE(rho, 0.65) << k;
    EXPECT_LE(rho, 1.0) << k;
    // The same prefix measured on the sampler's texels: the decoded surfels are those samples.
    EXPECT_NEAR(rho, measurePrefix(squareTexels(), blueOrder(), k).rho, 1e-3) << k;
  }
  // The whole payload through the whole-chunk decoder: the same cloud.
  auto whole = decodeSurfelChunkWithMesh(*payload, "p.mrg");
  ASSERT_TRUE(whole.ok()) << whole.error().message;
  EXPECT_EQ(whole->mesh, 7u);
  EXPECT_TRUE(samePrefix(whole->cloud, cloud) && whole->cloud.size() == cloud.size());
  EXPECT_EQ(*encodeSurfelChunk(whole->cloud, 7, kSmallBlocks), *payload);
  // A payload short of its last byte is truncated for the whole-chunk decoder.
  auto cut = decodeSurfelChunk(std::span(*payload).first(payload->size() - 1), "cut.mrg");
  ASSERT_FALSE(cut.ok());
  EXPECT_TRUE(contains(cut.error().message, "cut.mrg") && contains(cut.error().message, "truncated"))
      << cut.error().message;
}

TEST(SurfelBlocks, FlippedBytesAreRejectedNamingFileChunkAndBlock) {
  auto dir = test::tempDir("surfel_blocks_flip");
  std::string path = (dir / "flip.mrg").string();
  ASSERT_TRUE(writeSurfelMrg(path, blueCloud(), kSmallBlocks).ok());
  auto [payload, at] = surfPayload(path);
  auto table = asset::decodeBlockTable(payload, "p");
  ASSERT_TRUE(table.ok());
  std::ifstream in(path, std::ios::binary);
  const std::vector<uint8_t> valid((std::istreambuf_iterator<char>(in)), {});
  // Random bytes of the payload, and the first and last byte of the index and of every block.
  std::mt19937 rng(11);
  std::vector<size_t> flips = {0, size_t(table->indexBytes - 1)};
  for (const asset::BlockInfo& b : table->blocks) flips.insert(flips.end(), {b.offset, b.offset + b.storedBytes - 1});
  for (int i = 0; i < 300; ++i) flips.push_back(rng() % payload.size());
  for (size_t byte : flips) {
    std::vector<uint8_t> file = valid;
    file[at + byte] ^= uint8_t(1u << (rng() % 8));
    std::ofstream(path, std::ios::binary | std::ios::trunc)
        .write(reinterpret_cast<const char*>(file.data()), std::streamsize(file.size()));
    auto r = readSurfelMrgAll(path);
    ASSERT_FALSE(r.ok()) << "flip at payload byte " << byte << " accepted";
    const std::string& m = r.error().message;
    EXPECT_TRUE(contains(m, path + ": chunk 0 'SURF'")) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    if (byte < table->indexBytes) {
      EXPECT_TRUE(contains(m, "block index checksum mismatch")) << byte << ": " << m;
      continue;
    }
    size_t hit = 0;
    while (table->blocks[hit].offset + table->blocks[hit].storedBytes <= byte) ++hit;
    EXPECT_TRUE(contains(m, ": block " + std::to_string(hit) + " checksum mismatch")) << byte << ": " << m;
    // The blocks before the damaged one still decode as a prefix; with the damaged one, an error.
    std::span<const uint8_t> damaged(file.data() + at, payload.size());
    auto before = decodeSurfelPrefix(damaged.first(size_t(table->blocks[hit].offset)), "d.mrg");
    ASSERT_TRUE(before.ok()) << before.error().message;
    EXPECT_EQ(before->surfels.cloud.size(), hit ? surfelBlockEnds(4000, kSmallBlocks)[hit - 1] : 0u);
    auto with =
        decodeSurfelPrefix(damaged.first(size_t(table->blocks[hit].offset + table->blocks[hit].storedBytes)), "d.mrg");
    ASSERT_FALSE(with.ok());
    EXPECT_TRUE(contains(with.error().message, "d.mrg: block " + std::to_string(hit))) << with.error().message;
  }
}

TEST(SurfelBlocks, NumbersBehindValidChecksumsAreChecked) {
  SurfelCloud small = blueCloud();
  small.surfels.resize(300);
  small.radii.resize(300);
  small.referenceCount = 300;
  auto payload = encodeSurfelChunk(small, 0, kSmallBlocks);
  ASSERT_TRUE(payload.ok());
  auto table = asset::decodeBlockTable(*payload, "p");
  ASSERT_TRUE(table.ok());
  // Reassembled from its blocks with another header or another block: all checksums valid.
  auto rebuild = [&](std::vector<uint8_t> header, size_t block, std::vector<uint8_t> raw) {
    std::vector<asset::EncodedBlock> blocks;
    for (size_t i = 0; i < table->blocks.size(); ++i) {
      const asset::BlockInfo& b = table->blocks[i];
      asset::EncodedBlock e{
          b,
          {payload->begin() + std::ptrdiff_t(b.offset), payload->begin() + std::ptrdiff_t(b.offset + b.storedBytes)}};
      if (i == block) e = *asset::encodeBlock(raw, 3);
      blocks.push_back(std::move(e));
    }
    return *asset::assembleBlocks(header, blocks);
  };
  auto put = [](std::vector<uint8_t> bytes, size_t offset, auto value) {
    std::memcpy(bytes.data() + offset, &value, sizeof(value));
    return bytes;
  };
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<uint8_t>& h = table->header; // SurfelChunkHeader (48 bytes), mesh, pad
  struct Case {
    std::vector<uint8_t> payload;
    const char* expect;
  };
  auto block1 = asset::decodeBlocks(*payload, "p")->raw[1]; // 44 surfels, then their radii
  std::vector<Case> cases = {
      {rebuild(put(h, 16, nan), 99, {}), "box"},
      {rebuild(put(h, 28, -5.0f), 99, {}), "box"},
      {rebuild(put(h, 40, -1.0f), 99, {}), "spacing"},
      {rebuild(put(h, 8, uint32_t(301)), 99, {}), "spacing"},         // referenceCount above the count
      {rebuild(put(h, 4, uint32_t(301)), 99, {}), "header says 301"}, // count against the blocks
      {rebuild(put(h, 0, uint32_t(2)), 99, {}), "SURF chunk version 2 in a blocked payload"},
      {rebuild(std::vector<uint8_t>(h.begin(), h.end() - 1), 99, {}), "index header has 55 bytes"},
      {rebuild(h, 1, put(block1, 44 * 16 + 4, nan)), "block 1: radius 257 is negative"},
      {rebuild(h, 1, std::vector<uint8_t>(block1.begin(), block1.end() - 4)), "not whole 20-byte surfels"},
  };
  for (const Case& c : cases) {
    auto r = decodeSurfelChunkWithMesh(c.payload, "bad.mrg");
    ASSERT_FALSE(r.ok()) << c.expect;
    EXPECT_TRUE(contains(r.error().message, "bad.mrg: ")) << r.error().message;
    EXPECT_TRUE(contains(r.error().message, c.expect)) << c.expect << ": " << r.error().message;
    // The prefix reader checks the same numbers.
    EXPECT_FALSE(decodeSurfelPrefix(c.payload, "bad.mrg").ok()) << c.expect;
  }
}

TEST(SurfelBlocks, FileWrittenBeforeBlocksStillLoads) {
  // A whole-scene cloud written by the build before blocked chunks (mirage surfels gen:blob:1
  // --count 200 --resolution 32 --views 4): container version 1, one flat SURF chunk (version 2).
  std::string old = std::string(MIRAGE_SOURCE_DIR) + "/tests/surfels/data/surfels_v1.mrg";
  auto reader = asset::AssetReader::open(old);
  ASSERT_TRUE(reader.ok()) << reader.error().message;
  EXPECT_EQ(reader->version(), 1u);
  ASSERT_EQ(reader->chunks().size(), 1u);
  EXPECT_FALSE(reader->chunks()[0].blocked);
  EXPECT_TRUE(reader->chunks()[0].compressed);
  auto cloud = readSurfelMrg(old);
  ASSERT_TRUE(cloud.ok()) << cloud.error().message;
  ASSERT_EQ(cloud->size(), 200u);
  EXPECT_EQ(cloud->referenceCount, 200u);
  for (size_t i = 1; i < cloud->size(); ++i) EXPECT_LE(cloud->radii[i], cloud->radii[i - 1]) << i;
  auto prefix = decodeSurfelPrefix(*reader->readChunk(0), old); // flat: no blocks to stream
  EXPECT_FALSE(prefix.ok());
  // Rewritten by this build: blocked, version 2, the same cloud.
  auto dir = test::tempDir("surfel_blocks_old");
  std::string again = (dir / "again.mrg").string();
  ASSERT_TRUE(writeSurfelMrg(again, *cloud).ok());
  auto r2 = asset::AssetReader::open(again);
  ASSERT_TRUE(r2.ok());
  EXPECT_EQ(r2->version(), 2u);
  EXPECT_TRUE(r2->chunks()[0].blocked);
  auto back = readSurfelMrg(again);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_TRUE(samePrefix(*back, *cloud) && back->size() == cloud->size());
  EXPECT_EQ(back->box.min, cloud->box.min);
  EXPECT_EQ(back->box.max, cloud->box.max);
  EXPECT_EQ(back->referenceMedianSpacing, cloud->referenceMedianSpacing);
  // A flat payload inside a blocked entry (or the reverse) is refused: each layout has its checks.
  asset::AssetWriter w;
  w.addChunk(asset::chunk::Surfels, *encodeSurfelChunk(*cloud));
  std::string swapped = (dir / "swapped.mrg").string();
  ASSERT_TRUE(w.write(swapped).ok());
  auto s = readSurfelMrg(swapped);
  ASSERT_FALSE(s.ok());
  EXPECT_TRUE(contains(s.error().message, "layout does not match")) << s.error().message;
}
