// Surfel files from outside: a SURF chunk or surfel PLY whose numbers a renderer would compute with
// (box, spacings, radii, positions) is rejected on decode with one line, and a vertex count the
// file cannot hold is rejected before anything is allocated for it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>

#include "mirage/surfels/surfel_io.h"
#include "test_support.h"

using namespace mirage;
using namespace mirage::surfels;

namespace {

SurfelCloud smallCloud() {
  SurfelCloud c;
  c.box.add(glm::vec3(0.0f));
  c.box.add(glm::vec3(1.0f));
  c.surfels = {packSurfel(c.box, glm::vec3(0.5f), {0, 0, 1}, 0xff0000ffu),
               packSurfel(c.box, glm::vec3(0.2f), {0, 1, 0}, 0xff00ff00u)};
  c.radii = {0.5f, 0.25f};
  c.referenceCount = 2;
  return c;
}

template <class T> void put(std::vector<uint8_t>& bytes, size_t at, T v) {
  std::memcpy(bytes.data() + at, &v, sizeof(T));
}

} // namespace

TEST(SurfelIo, ChunkWithNonFiniteOrInconsistentNumbersIsRejected) {
  std::vector<uint8_t> good = encodeSurfelChunkFlat(smallCloud(), 0);
  ASSERT_TRUE(decodeSurfelChunkWithMesh(good, "good").ok());
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  struct Damage {
    size_t offset;
    float value;
    const char* what;
  };
  // Header: version, count, referenceCount, pad, boxMin[3] at 16, boxMax[3] at 28, spacings at 40
  // and 44; then mesh, pad, 2 surfels of 16 bytes, 2 radii at 56 + 32.
  for (Damage d : {Damage{16, nan, "box"}, Damage{32, inf, "box"}, Damage{28, -5.0f, "box"}, Damage{40, nan, "spacing"},
                   Damage{44, -1.0f, "spacing"}, Damage{88, nan, "radius"}, Damage{92, -1.0f, "radius"}}) {
    std::vector<uint8_t> bad = good;
    put(bad, d.offset, d.value);
    auto r = decodeSurfelChunkWithMesh(bad, "bad.mrg");
    ASSERT_FALSE(r.ok()) << d.what << " at " << d.offset << " accepted";
    EXPECT_NE(r.error().message.find("bad.mrg"), std::string::npos);
  }
  std::vector<uint8_t> bad = good;
  put(bad, 8, uint32_t(3)); // referenceCount above the count
  EXPECT_FALSE(decodeSurfelChunkWithMesh(bad, "bad.mrg").ok());
}

TEST(SurfelIo, PlyCountsAndNumbersAreChecked) {
  auto dir = test::tempDir("surfel_io_ply");
  std::string header = "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\n"
                       "property float z\nproperty float radius\nend_header\n";
  auto write = [&](const std::string& name, uint64_t count, const std::vector<float>& values) {
    std::string h = header;
    h.replace(h.find("{}"), 2, std::to_string(count));
    std::ofstream f(dir / name, std::ios::binary);
    f << h;
    f.write(reinterpret_cast<const char*>(values.data()), std::streamsize(values.size() * sizeof(float)));
    return (dir / name).string();
  };
  std::vector<float> two = {0, 0, 0, 0.1f, 1, 1, 1, 0.2f};
  auto ok = readSurfelPly(write("ok.ply", 2, two));
  ASSERT_TRUE(ok.ok()) << ok.error().message;
  EXPECT_EQ(ok->size(), 2u);
  // A count far beyond the data (it allocated count * stride bytes first), one too many, one too few.
  for (uint64_t count : {uint64_t(1) << 60, uint64_t(3), uint64_t(1)}) {
    auto r = readSurfelPly(write("count.ply", count, two));
    ASSERT_FALSE(r.ok()) << count;
    EXPECT_NE(r.error().message.find(std::to_string(count)), std::string::npos) << r.error().message;
  }
  std::vector<float> nanPoint = two;
  nanPoint[4] = std::numeric_limits<float>::quiet_NaN();
  auto r = readSurfelPly(write("nan.ply", 2, nanPoint));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("vertex 1"), std::string::npos) << r.error().message;
}
