// PLY specifics: triangle strips (element tristrips, -1 restarts, alternating winding), index property names, and
// counts that disagree with the data (short data, trailing bytes) in both encodings.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <fstream>
#include <set>

#include <meshoptimizer.h>

#include "mirage/io/import.h"
#include "mirage/io/mesh_utils.h"
#include "import_test_util.h"
#include "support/test_support.h"

using namespace mirage;

namespace {

using test::expectError;
using test::put;
using test::writeFile;

io::ImportOptions raw() {
  io::ImportOptions o;
  o.weld = false; // keep the file's vertex numbering so triangles compare index by index
  return o;
}

// A triangle as its corner indices rotated to start at the smallest: equal for equal winding, whatever the start.
std::array<uint32_t, 3> canonical(uint32_t a, uint32_t b, uint32_t c) {
  if (b < a && b < c) return {b, c, a};
  if (c < a && c < b) return {c, a, b};
  return {a, b, c};
}

std::multiset<std::array<uint32_t, 3>> triangles(const std::vector<uint32_t>& idx) {
  std::multiset<std::array<uint32_t, 3>> out;
  for (size_t i = 0; i + 2 < idx.size(); i += 3) out.insert(canonical(idx[i], idx[i + 1], idx[i + 2]));
  return out;
}

// 6 vertices of a 3x2 grid (z = 0).
const char* kGridVertices = "0 0 0\n1 0 0\n2 0 0\n0 1 0\n1 1 0\n2 1 0\n";

std::string asciiHeader(const std::string& elements) {
  return "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\nproperty float z\n" + elements +
         "end_header\n" + kGridVertices;
}

} // namespace

// Strip 3 0 4 1, a restart, then strip 4 1 5 2: the second triangle of each run is flipped (a strip alternates
// winding), so all four triangles face +z like the first of each run.
TEST(ImportPly, AsciiTriangleStripsWithRestart) {
  auto dir = test::tempDir("ply_strips");
  auto path = writeFile(dir / "strips.ply", asciiHeader("element tristrips 1\nproperty list int int vertex_indices\n") +
                                                "9 3 0 4 1 -1 4 1 5 2\n");
  auto scene = io::importPly(path, raw());
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  ASSERT_EQ(scene->meshes.size(), 1u);
  const Mesh& m = scene->meshes[0];
  std::multiset<std::array<uint32_t, 3>> want = {canonical(3, 0, 4), canonical(4, 0, 1), canonical(4, 1, 5),
                                                 canonical(5, 1, 2)};
  EXPECT_EQ(triangles(m.indices), want);
  for (size_t t = 0; t < m.indices.size(); t += 3) { // every triangle faces the same way
    glm::vec3 a = m.positions[m.indices[t]], b = m.positions[m.indices[t + 1]], c = m.positions[m.indices[t + 2]];
    EXPECT_GT(glm::cross(b - a, c - a).z, 0.0f) << "triangle " << t / 3;
  }
}

// Zero-area stitch triangles (a repeated index) carry no surface and are dropped.
TEST(ImportPly, StripStitchesDropped) {
  auto dir = test::tempDir("ply_strip_stitch");
  auto path = writeFile(dir / "stitch.ply", asciiHeader("element tristrips 1\nproperty list int int vertex_index\n") +
                                                "8 3 0 4 1 1 4 2 5\n");
  auto scene = io::importPly(path, raw());
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  EXPECT_EQ(scene->meshes[0].triangleCount(), 4u);
}

// The face list may be called vertex_index as well as vertex_indices.
TEST(ImportPly, FaceListNamedVertexIndex) {
  auto dir = test::tempDir("ply_vertex_index");
  auto path = writeFile(dir / "vi.ply",
                        asciiHeader("element face 2\nproperty list uchar int vertex_index\n") + "3 0 1 4\n3 0 4 3\n");
  auto scene = io::importPly(path, raw());
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  EXPECT_EQ(scene->meshes[0].triangleCount(), 2u);
}

// A strips-only file holds triangles for every command: with point clouds allowed it is still a mesh.
TEST(ImportPly, StripsOnlyIsNotAPointCloud) {
  auto dir = test::tempDir("ply_strips_pc");
  auto path = writeFile(dir / "strips.ply",
                        asciiHeader("element tristrips 1\nproperty list int int vertex_indices\n") + "4 3 0 4 1\n");
  io::ImportOptions o;
  o.allowPointClouds = true;
  auto scene = io::importPly(path, o);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  EXPECT_EQ(scene->meshTriangleCount(), 2u);
}

// A real scan stripified (meshoptimizer, -1 restarts) and written as binary tristrips imports to the same triangles.
TEST(ImportPly, BinaryStripsOfARealScanMatchTheFaces) {
  MIRAGE_REQUIRE_DATA(horse, "cyberware-horse/horse.ply");
  auto faces = io::importPly(horse, raw());
  ASSERT_TRUE(faces.ok()) << faces.error().message;
  const Mesh& m = faces->meshes[0];
  std::vector<uint32_t> strip(meshopt_stripifyBound(m.indices.size()));
  strip.resize(meshopt_stripify(strip.data(), m.indices.data(), m.indices.size(), m.positions.size(), ~0u));
  std::string ply = "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(m.positions.size()) +
                    "\nproperty float x\nproperty float y\nproperty float z\nelement tristrips 1\n"
                    "property list int int vertex_indices\nend_header\n";
  for (const glm::vec3& p : m.positions) ply.append(reinterpret_cast<const char*>(&p), 12);
  put<int32_t>(ply, int32_t(strip.size()));
  for (uint32_t i : strip) put<int32_t>(ply, i == ~0u ? -1 : int32_t(i));
  auto dir = test::tempDir("ply_horse_strips");
  auto stripped = io::importPly(writeFile(dir / "horse_strips.ply", ply), raw());
  ASSERT_TRUE(stripped.ok()) << stripped.error().message;
  // The stripifier keeps every non-degenerate triangle with its winding.
  std::vector<uint32_t> kept;
  for (size_t t = 0; t < m.indices.size(); t += 3) {
    uint32_t a = m.indices[t], b = m.indices[t + 1], c = m.indices[t + 2];
    if (a != b && b != c && a != c) kept.insert(kept.end(), {a, b, c});
  }
  EXPECT_EQ(triangles(stripped->meshes[0].indices), triangles(kept));
}

// Binary: a face count smaller than the data would drop triangles silently; the error names both counts.
TEST(ImportPly, BinaryTrailingRecordsRejected) {
  std::string ply = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                    "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  for (float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) put<float>(ply, v);
  for (int f = 0; f < 3; ++f) {
    ply += char(3);
    for (int32_t i : {0, 1, 2}) put<int32_t>(ply, i);
  }
  auto dir = test::tempDir("ply_trailing");
  auto path = writeFile(dir / "trailing.ply", ply);
  expectError(io::importPly(path), path, "element 'face' declares 1 records, the data holds 3");
  // Bytes that are not whole records are reported as bytes.
  auto junk = writeFile(dir / "junk.ply", ply.substr(0, ply.size() - 13 * 2) + "xy");
  expectError(io::importPly(junk), junk, "element 'face' declares 1 records but 2 more bytes follow them");
}

// Binary: a vertex count too large swallows the first face's bytes; what is left is no longer valid faces.
TEST(ImportPly, BinaryVertexCountTooLargeRejected) {
  std::string body;
  for (float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) put<float>(body, v);
  for (int f = 0; f < 2; ++f) {
    body += char(3);
    for (int32_t i : {0, 1, 2}) put<int32_t>(body, i);
  }
  std::string ply = "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                    "property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n" +
                    body;
  auto dir = test::tempDir("ply_vertex_count");
  auto path = writeFile(dir / "vcount.ply", ply);
  auto r = io::importPly(path);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find(path.string()), std::string::npos) << r.error().message;
  // A point cloud (no faces) with too many vertices declared.
  std::string pts = "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                    "property float z\nend_header\n" +
                    body.substr(0, 36) + "abcdefgh";
  auto cloud = writeFile(dir / "cloud.ply", pts);
  io::ImportOptions o;
  o.allowPointClouds = true;
  expectError(io::importPly(cloud, o), cloud, "element 'vertex' declares 4 records, the data holds 3");
}

// An element without properties holds no bytes: data after it cannot be counted in its records (and must not hang).
TEST(ImportPly, TrailingBytesAfterAnEmptyElement) {
  auto dir = test::tempDir("ply_empty_element");
  std::string ply = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                    "property float z\nelement face 1\nproperty list uchar int vertex_indices\nelement nothing 2\n"
                    "end_header\n";
  for (float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) put<float>(ply, v);
  ply += char(3);
  for (int32_t i : {0, 1, 2}) put<int32_t>(ply, i);
  auto path = writeFile(dir / "empty_element.ply", ply + "zz");
  expectError(io::importPly(path), path, "element 'nothing' declares 2 records but 2 more bytes follow them");
  EXPECT_TRUE(io::importPly(writeFile(dir / "exact.ply", ply)).ok());
}

// ASCII: both directions.
TEST(ImportPly, AsciiCountsMustMatchData) {
  auto dir = test::tempDir("ply_ascii_counts");
  auto extra = writeFile(dir / "extra.ply", asciiHeader("element face 1\nproperty list uchar int vertex_indices\n") +
                                                "3 0 1 4\n3 0 4 3\n3 1 2 5\n");
  expectError(io::importPly(extra), extra, "element 'face' declares 1 records, the data holds 3");
  auto shortData =
      writeFile(dir / "short.ply",
                asciiHeader("element face 3\nproperty list uchar int vertex_indices\n") + "3 0 1 4\n3 0 4 3\n");
  expectError(io::importPly(shortData), shortData, "element 'face' declares 3 records, the data holds 2");
  // Trailing white space is not data.
  auto spaces = writeFile(dir / "spaces.ply",
                          asciiHeader("element face 1\nproperty list uchar int vertex_indices\n") + "3 0 1 4\n\n  \n");
  EXPECT_TRUE(io::importPly(spaces).ok());
}

// Header lines with control bytes are quoted escaped, never echoed raw.
TEST(ImportPly, HeaderErrorsEscapeInputBytes) {
  auto dir = test::tempDir("ply_escape");
  auto path = writeFile(dir / "esc.ply", std::string("ply\nformat bin\x01\xff\x1b[31m 1.0\nend_header\n"));
  auto r = io::importPly(path);
  expectError(r, path, "unknown PLY format 'bin\\x01\\xff\\x1b[31m'");
}
