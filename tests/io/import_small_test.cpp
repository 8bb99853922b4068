// Hand-made files with known answers: exact geometry, welding, normals, hierarchy transforms, and bad input.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>

#include <glm/gtc/matrix_transform.hpp>
#include <meshoptimizer.h>
#include <random>
#include <set>
#include <stb/stb_image_write.h>

#include "mirage/io/import.h"
#include "mirage/io/generate.h"
#include "mirage/io/gltf_write.h"
#include "mirage/io/mesh_utils.h"
#include "mirage/io/ply_write.h"
#include "import_test_util.h"
#include "support/test_support.h"

using namespace mirage;

namespace {

using test::expectError;
using test::put;
using test::writeFile;

// A binary PLY: a unit quad as one 4-gon, with an extra per-vertex property and an extra element to skip.
std::string quadPly(bool bigEndian, bool truncate = false) {
  std::string h = std::string("ply\nformat ") + (bigEndian ? "binary_big_endian" : "binary_little_endian") +
                  " 1.0\ncomment test\nelement vertex 4\nproperty double x\nproperty float y\nproperty float z\n"
                  "property uchar quality\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
                  "element extra 2\nproperty list uchar int stuff\nproperty short s\n"
                  "element face 1\nproperty uchar flags\nproperty list uchar uint vertex_indices\nend_header\n";
  const float xy[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  for (auto& v : xy) {
    put<double>(h, v[0], bigEndian);
    put<float>(h, v[1], bigEndian);
    put<float>(h, 0.0f, bigEndian);
    h += char(7);
    h += char(255), h += char(0), h += char(0);
  }
  for (int e = 0; e < 2; ++e) {
    h += char(2);
    put<int32_t>(h, 5, bigEndian);
    put<int32_t>(h, 6, bigEndian);
    put<int16_t>(h, 9, bigEndian);
  }
  h += char(0);
  h += char(4);
  for (uint32_t i : {0u, 1u, 2u, 3u}) put<uint32_t>(h, i, bigEndian);
  if (truncate) h.resize(h.size() - 6);
  return h;
}

} // namespace

TEST(MeshUtils, FlatQuadNormalsAndWeld) {
  Mesh m;
  // Two triangles of the z=0 unit quad with the shared edge duplicated: 6 vertices, 4 distinct.
  m.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  m.indices = {0, 1, 2, 3, 4, 5};
  io::weldMesh(m);
  EXPECT_EQ(m.vertexCount(), 4u);
  EXPECT_EQ(m.triangleCount(), 2u);
  io::computeNormals(m);
  for (const glm::vec3& n : m.normals) EXPECT_NEAR(glm::distance(n, glm::vec3(0, 0, 1)), 0.0f, 1e-6f);
  io::computeBounds(m);
  EXPECT_EQ(m.bounds.min, glm::vec3(0, 0, 0));
  EXPECT_EQ(m.bounds.max, glm::vec3(1, 1, 0));
  EXPECT_TRUE(io::validateMesh(m, "x").ok());
  m.uv0 = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  io::computeTangents(m);
  ASSERT_EQ(m.tangents.size(), 4u);
  EXPECT_NEAR(glm::distance(glm::vec3(m.tangents[0]), glm::vec3(1, 0, 0)), 0.0f, 1e-5f);
}

TEST(MeshUtils, AreaWeightedNormal) {
  // Vertex 0 is shared by a big triangle facing +Z and a small one facing +X: the normal leans to +Z by area.
  Mesh m;
  m.positions = {{0, 0, 0}, {4, 0, 0}, {0, 4, 0}, {0, 1, 0}, {0, 0, 1}};
  m.indices = {0, 1, 2, 0, 3, 4};
  io::computeNormals(m);
  glm::vec3 expect = glm::normalize(glm::vec3(0, 0, 16) + glm::vec3(1, 0, 0));
  EXPECT_NEAR(glm::distance(m.normals[0], expect), 0.0f, 1e-6f);
}

TEST(MeshUtils, WeldKeepsDistinctAttributes) {
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.uv0 = {{0, 0}, {1, 0}, {0, 1}, {0.5f, 0}, {1, 0}, {0, 1}}; // a UV seam at vertex 0
  m.indices = {0, 1, 2, 3, 4, 5};
  io::weldMesh(m);
  EXPECT_EQ(m.vertexCount(), 4u);
}

// weldMesh must find exactly the unique vertices meshopt's remap finds, and map every corner to an equal vertex.
TEST(MeshUtils, WeldAgreesWithMeshopt) {
  std::mt19937 rng(7);
  Mesh m;
  const int distinct = 500;
  for (int i = 0; i < 30000; ++i) { // 30000 corners drawn from 500 positions x 2 uv values
    int k = int(rng() % distinct);
    m.positions.push_back(glm::vec3(float(k % 10), float(k / 10 % 10), float(k / 100)));
    m.uv0.push_back(glm::vec2(float(rng() % 2), 0.0f));
    m.indices.push_back(uint32_t(i));
  }
  m.positions.push_back(glm::vec3(99.0f)); // one vertex no triangle uses
  m.uv0.push_back(glm::vec2(0.0f));
  Mesh before = m;
  std::vector<unsigned> remap(before.positions.size());
  meshopt_Stream streams[] = {{before.positions.data(), 12, 12}, {before.uv0.data(), 8, 8}};
  size_t expected = meshopt_generateVertexRemapMulti(remap.data(), before.indices.data(), before.indices.size(),
                                                     before.positions.size(), streams, 2);
  io::weldMesh(m);
  EXPECT_EQ(m.vertexCount(), expected);
  EXPECT_EQ(m.vertexCount(), 1000u);
  ASSERT_EQ(m.indices.size(), before.indices.size());
  for (size_t i = 0; i < m.indices.size(); ++i) {
    ASSERT_EQ(m.positions[m.indices[i]], before.positions[before.indices[i]]);
    ASSERT_EQ(m.uv0[m.indices[i]], before.uv0[before.indices[i]]);
  }
}

TEST(MeshUtils, ValidateRejects) {
  Mesh m;
  m.name = "t";
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.indices = {0, 1, 3};
  EXPECT_NE(io::validateMesh(m, "f").error().message.find("out of range"), std::string::npos);
  m.indices = {0, 1};
  EXPECT_NE(io::validateMesh(m, "f").error().message.find("multiple of 3"), std::string::npos);
  m.indices = {0, 1, 2};
  m.positions[1].y = std::nanf("");
  EXPECT_NE(io::validateMesh(m, "f").error().message.find("non-finite"), std::string::npos);
  m.indices.clear();
  EXPECT_NE(io::validateMesh(m, "f").error().message.find("empty"), std::string::npos);
}

TEST(ImportObj, QuadWeldNormalsAndMaterials) {
  auto dir = test::tempDir("obj-quad");
  writeFile(dir / "q.mtl", "newmtl red\nKd 1 0 0\nd 0.5\nNs 98\nnewmtl blue\nKd 0 0 1\n");
  auto obj = writeFile(dir / "q.obj", "# quad twice\nmtllib q.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                                      "v 0 0 0\nv 1 1 0\nusemtl red\nf 1 2 3\nf 5 6 4\n"
                                      "usemtl blue\nf -6/ -5 -4 -3\n");
  auto r = io::importScene(obj);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->meshes.size(), 2u);
  const Mesh& red = r->meshes[0];
  EXPECT_EQ(red.triangleCount(), 2u);
  EXPECT_EQ(red.vertexCount(), 4u); // v5/v6 duplicate v1/v3 and are welded
  for (const glm::vec3& n : red.normals) EXPECT_NEAR(glm::distance(n, glm::vec3(0, 0, 1)), 0.0f, 1e-6f);
  EXPECT_EQ(r->meshes[1].triangleCount(), 2u); // the quad face is fan-triangulated
  const Material& mr = r->materials[red.material];
  EXPECT_EQ(mr.name, "red");
  EXPECT_EQ(mr.baseColorFactor, glm::vec4(1, 0, 0, 0.5f));
  EXPECT_EQ(mr.alphaMode, AlphaMode::Blend);
  EXPECT_NEAR(mr.roughnessFactor, std::sqrt(2.0f / 100.0f), 1e-6f);
  EXPECT_EQ(r->materials[r->meshes[1].material].baseColorFactor, glm::vec4(0, 0, 1, 1));
  EXPECT_EQ(r->instances.size(), 2u);

  io::ImportOptions noWeld;
  noWeld.weld = false;
  auto raw = io::importObj(obj, noWeld);
  ASSERT_TRUE(raw.ok());
  EXPECT_EQ(raw->meshes[0].vertexCount(), 6u);
}

TEST(ImportObj, TexcoordsAndNormalsFromFile) {
  auto dir = test::tempDir("obj-attrs");
  auto obj = writeFile(dir / "t.OBJ", "v 0 0 0\nv 2 0 0\nv 0 2 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 -1\n"
                                      "f 1/1/1 2/2/1 3/3/1\n");
  auto r = io::importScene(obj); // upper-case extension dispatches too
  ASSERT_TRUE(r.ok()) << r.error().message;
  const Mesh& m = r->meshes[0];
  ASSERT_EQ(m.uv0.size(), 3u);
  EXPECT_EQ(m.uv0[2], glm::vec2(0, 0));         // v flipped to top-left origin
  EXPECT_EQ(m.normals[0], glm::vec3(0, 0, -1)); // file normals are kept, not recomputed
  EXPECT_EQ(m.positions[1], glm::vec3(2, 0, 0));
}

TEST(ImportPly, AsciiExactValues) {
  auto dir = test::tempDir("ply-ascii");
  auto ply = writeFile(dir / "a.ply", "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                                      "property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
                                      "element face 1\nproperty list uchar int vertex_index\nend_header\n"
                                      "0 0 0 0 0 1\n2 0 0 0 0 1\n2 3 0 0 0 1\n0 3 0 0 0 1\n4 0 1 2 3\n");
  auto r = io::importPly(ply);
  ASSERT_TRUE(r.ok()) << r.error().message;
  const Mesh& m = r->meshes[0];
  EXPECT_EQ(m.triangleCount(), 2u);
  EXPECT_EQ(m.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
  EXPECT_EQ(m.positions[2], glm::vec3(2, 3, 0));
  EXPECT_EQ(m.bounds.max, glm::vec3(2, 3, 0));
}

TEST(ImportPly, BinaryBothEndiansSkipExtras) {
  auto dir = test::tempDir("ply-bin");
  for (bool big : {false, true}) {
    SCOPED_TRACE(big ? "big endian" : "little endian");
    auto ply = writeFile(dir / (big ? "be.ply" : "le.ply"), quadPly(big));
    auto r = io::importPly(ply);
    ASSERT_TRUE(r.ok()) << r.error().message;
    const Mesh& m = r->meshes[0];
    ASSERT_EQ(m.vertexCount(), 4u);
    EXPECT_EQ(m.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
    EXPECT_EQ(m.positions[2], glm::vec3(1, 1, 0));
    ASSERT_EQ(m.colors.size(), 4u);
    EXPECT_EQ(m.colors[0], glm::vec4(1, 0, 0, 1)); // 255,0,0 sRGB is linear 1,0,0
    for (const glm::vec3& n : m.normals) EXPECT_NEAR(glm::distance(n, glm::vec3(0, 0, 1)), 0.0f, 1e-6f);
  }
}

// A glTF with a parent/child hierarchy and a mesh shared by two nodes.
TEST(ImportGltf, HierarchyTransformsAndSharing) {
  auto dir = test::tempDir("gltf-tree");
  std::string bin;
  for (float f : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) put(bin, f);
  for (uint16_t i : {0, 1, 2}) put(bin, i);
  bin += std::string(2, '\0');
  writeFile(dir / "tri.bin", bin);
  auto gltf = writeFile(dir / "tree.gltf", R"({
  "asset": {"version": "2.0"}, "scene": 0,
  "scenes": [{"nodes": [0, 2]}],
  "nodes": [
    {"translation": [10, 0, 0], "scale": [2, 2, 2], "children": [1]},
    {"rotation": [0, 0, 0.7071067811865476, 0.7071067811865476], "mesh": 0},
    {"matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,-5,1], "mesh": 0},
    {"mesh": 0}
  ],
  "meshes": [{"name": "tri", "primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
  "accessors": [
    {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]},
    {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}
  ],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
  "buffers": [{"uri": "tri.bin", "byteLength": 44}]
})");
  auto r = io::importGltf(gltf);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->meshes.size(), 1u);    // shared by both nodes
  ASSERT_EQ(r->instances.size(), 2u); // node 3 is not in the scene
  EXPECT_EQ(r->materials.size(), 1u); // default material
  auto apply = [](const glm::mat4& m, glm::vec3 p) { return glm::vec3(m * glm::vec4(p, 1)); };
  // Child: translate(10) * scale(2) * rotZ(90): (1,0,0) -> (0,1,0) -> (0,2,0) -> (10,2,0).
  EXPECT_NEAR(glm::distance(apply(r->instances[0].transform, {1, 0, 0}), glm::vec3(10, 2, 0)), 0.0f, 1e-5f);
  EXPECT_NEAR(glm::distance(apply(r->instances[1].transform, {0, 1, 0}), glm::vec3(0, 1, -5)), 0.0f, 1e-6f);
  EXPECT_EQ(r->instancedTriangleCount(), 2u);
  EXPECT_EQ(r->meshTriangleCount(), 1u);

  // The same file without its .bin must fail cleanly.
  std::filesystem::remove(dir / "tri.bin");
  auto missing = io::importGltf(gltf);
  expectError(missing, gltf, "tri.bin");
}

// KHR_mesh_quantization-style accessors (u16 positions, normalized i8 normals, u16 UVs, u8 colours), a sparse
// accessor and a triangle strip without indices.
TEST(ImportGltf, QuantizedSparseStrip) {
  auto dir = test::tempDir("gltf-quant");
  std::string bin;
  const uint16_t pos[4][3] = {{0, 0, 0}, {100, 0, 0}, {0, 100, 0}, {100, 100, 0}};
  for (auto& v : pos) {
    for (uint16_t c : v) put(bin, c);
    put<uint16_t>(bin, 0); // stride 8: components padded to 4-byte alignment
  }
  for (int i = 0; i < 4; ++i) bin += std::string{char(0), char(0), char(127), char(0)};
  const uint16_t uv[4][2] = {{0, 0}, {65535, 0}, {0, 65535}, {65535, 65535}};
  for (auto& t : uv) put(bin, t[0]), put(bin, t[1]);
  for (int i = 0; i < 4; ++i) bin += std::string{char(255), char(0), char(i == 3 ? 255 : 0), char(255)};
  bin += std::string{char(3), 0, 0, 0};          // sparse index: vertex 3
  for (uint16_t c : {100, 100, 50}) put(bin, c); // sparse value
  bin += std::string(2, '\0');
  ASSERT_EQ(bin.size(), 92u);
  writeFile(dir / "q.bin", bin);
  auto gltf = writeFile(dir / "q.gltf", R"({
  "asset": {"version": "2.0"}, "extensionsUsed": ["KHR_mesh_quantization"], "extensionsRequired": ["KHR_mesh_quantization"],
  "nodes": [{"scale": [0.01, 0.01, 0.01], "mesh": 0}],
  "meshes": [{"primitives": [{"mode": 5, "material": 0,
    "attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2, "COLOR_0": 3}}]}],
  "materials": [{"name": "m", "alphaMode": "MASK", "alphaCutoff": 0.25, "doubleSided": true,
                 "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0.0}}],
  "accessors": [
    {"bufferView": 0, "componentType": 5123, "count": 4, "type": "VEC3", "min": [0,0,0], "max": [100,100,50],
     "sparse": {"count": 1, "indices": {"bufferView": 4, "componentType": 5121}, "values": {"bufferView": 5}}},
    {"bufferView": 1, "componentType": 5120, "normalized": true, "count": 4, "type": "VEC3"},
    {"bufferView": 2, "componentType": 5123, "normalized": true, "count": 4, "type": "VEC2"},
    {"bufferView": 3, "componentType": 5121, "normalized": true, "count": 4, "type": "VEC4"}
  ],
  "bufferViews": [
    {"buffer": 0, "byteOffset": 0, "byteLength": 32, "byteStride": 8},
    {"buffer": 0, "byteOffset": 32, "byteLength": 16, "byteStride": 4},
    {"buffer": 0, "byteOffset": 48, "byteLength": 16},
    {"buffer": 0, "byteOffset": 64, "byteLength": 16},
    {"buffer": 0, "byteOffset": 80, "byteLength": 1},
    {"buffer": 0, "byteOffset": 84, "byteLength": 6}
  ],
  "buffers": [{"uri": "q.bin", "byteLength": 92}]
})");
  io::ImportOptions opt;
  opt.weld = false;
  auto r = io::importGltf(gltf, opt);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->meshes.size(), 1u);
  const Mesh& m = r->meshes[0];
  EXPECT_EQ(m.indices, (std::vector<uint32_t>{0, 1, 2, 2, 1, 3})); // strip order keeps the winding
  EXPECT_EQ(m.positions[1], glm::vec3(100, 0, 0));
  EXPECT_EQ(m.positions[3], glm::vec3(100, 100, 50)); // from the sparse substitution
  EXPECT_NEAR(glm::distance(m.normals[0], glm::vec3(0, 0, 1)), 0.0f, 1e-6f);
  EXPECT_EQ(m.uv0[3], glm::vec2(1, 1));
  EXPECT_EQ(m.colors[3], glm::vec4(1, 0, 1, 1));
  const Material& mat = r->materials[m.material];
  EXPECT_EQ(mat.alphaMode, AlphaMode::Mask);
  EXPECT_FLOAT_EQ(mat.alphaCutoff, 0.25f);
  EXPECT_TRUE(mat.doubleSided);
  EXPECT_FLOAT_EQ(mat.metallicFactor, 0.0f);
  Bounds wb = r->worldBounds();
  EXPECT_NEAR(wb.max.x, 1.0f, 1e-6f);
  EXPECT_NEAR(wb.max.z, 0.5f, 1e-6f);
}

// One image used as base colour (sRGB) and as normal map (linear) becomes two Textures; OBJ map_Kd loads too.
TEST(ImportTextures, SrgbAndLinearCopiesAndObjMaps) {
  auto dir = test::tempDir("tex");
  const uint8_t px[2 * 2 * 3] = {255, 0, 0, 0, 255, 0, 0, 0, 255, 10, 20, 30};
  ASSERT_NE(stbi_write_png((dir / "t.png").c_str(), 2, 2, 3, px, 6), 0);
  std::string bin;
  for (float f : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) put(bin, f);
  writeFile(dir / "t.bin", bin);
  auto gltf = writeFile(dir / "t.gltf", R"({"asset": {"version": "2.0"}, "nodes": [{"mesh": 0}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}],
  "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}, "normalTexture": {"index": 0, "scale": 0.5},
                 "occlusionTexture": {"index": 0, "strength": 0.25}}],
  "textures": [{"source": 0}], "images": [{"uri": "t.png"}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}],
  "bufferViews": [{"buffer": 0, "byteLength": 36}], "buffers": [{"uri": "t.bin", "byteLength": 36}]})");
  auto r = io::importGltf(gltf);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->textures.size(), 2u);
  const Material& m = r->materials[0];
  EXPECT_TRUE(r->textures[m.baseColorTexture].srgb);
  EXPECT_FALSE(r->textures[m.normalTexture].srgb);
  EXPECT_EQ(m.normalTexture, m.occlusionTexture); // linear uses share one copy
  EXPECT_FLOAT_EQ(m.normalScale, 0.5f);
  EXPECT_FLOAT_EQ(m.occlusionStrength, 0.25f);
  const Texture& t = r->textures[m.baseColorTexture];
  ASSERT_EQ(t.rgba8.size(), 16u);
  EXPECT_EQ(std::vector<uint8_t>(t.rgba8.begin() + 12, t.rgba8.end()), (std::vector<uint8_t>{10, 20, 30, 255}));

  io::ImportOptions noTex;
  noTex.loadTextures = false;
  auto bare = io::importGltf(gltf, noTex);
  ASSERT_TRUE(bare.ok()) << bare.error().message;
  EXPECT_TRUE(bare->textures.empty());
  EXPECT_EQ(bare->materials[0].baseColorTexture, -1);

  writeFile(dir / "t.mtl", "newmtl a\nmap_Kd -s 1 1 1 t.png\nmap_bump t.png\nnewmtl b\n");
  auto obj =
      writeFile(dir / "t.obj", "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\nusemtl b\nf 3 2 1\n");
  auto o = io::importObj(obj);
  ASSERT_TRUE(o.ok()) << o.error().message;
  ASSERT_EQ(o->textures.size(), 2u);
  EXPECT_TRUE(o->textures[o->materials[0].baseColorTexture].srgb);
  EXPECT_FALSE(o->textures[o->materials[0].normalTexture].srgb);
  EXPECT_EQ(o->materials[1].baseColorTexture, -1); // no map: untextured (a missing map is an error, see hardening)
}

TEST(ImportGltf, KhrTextureTransform) {
  auto dir = test::tempDir("texture_transform");
  const uint8_t px[4] = {255, 255, 255, 255};
  ASSERT_NE(stbi_write_png((dir / "w.png").c_str(), 1, 1, 4, px, 4), 0);
  std::string bin;
  for (float f : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) put(bin, f);
  writeFile(dir / "t.bin", bin);
  auto gltf = writeFile(dir / "t.gltf", R"({"asset": {"version": "2.0"}, "nodes": [{"mesh": 0}],
  "extensionsUsed": ["KHR_texture_transform"],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}],
  "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform":
                   {"offset": [0.5, 0.25], "rotation": 1.5, "scale": [2, 3]}}}},
                 "normalTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"scale": [4, "x"]}}}}],
  "textures": [{"source": 0}], "images": [{"uri": "w.png"}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}],
  "bufferViews": [{"buffer": 0, "byteLength": 36}], "buffers": [{"uri": "t.bin", "byteLength": 36}]})");
  auto r = io::importGltf(gltf);
  ASSERT_TRUE(r.ok()) << r.error().message;
  const UvTransform& base = r->materials[0].uv[kMapBaseColor];
  EXPECT_EQ(base.offset, glm::vec2(0.5f, 0.25f));
  EXPECT_EQ(base.scale, glm::vec2(2, 3));
  EXPECT_FLOAT_EQ(base.rotation, 1.5f);
  EXPECT_EQ(r->materials[0].uv[kMapNormal].scale, glm::vec2(1, 1)); // malformed: the identity
  EXPECT_EQ(r->materials[0].uv[kMapOcclusion].scale, glm::vec2(1, 1));
}

TEST(ImportGltf, KhrLightsPunctualPointLights) {
  auto dir = test::tempDir("lights");
  std::string bin;
  for (float f : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) put(bin, f);
  writeFile(dir / "t.bin", bin);
  auto gltf = writeFile(dir / "l.gltf", R"({"asset": {"version": "2.0"},
  "extensionsUsed": ["KHR_lights_punctual"],
  "extensions": {"KHR_lights_punctual": {"lights": [
    {"type": "point", "color": [1, 0.5, 0.25], "intensity": 4, "range": 7},
    {"type": "point", "intensity": 10},
    {"type": "spot", "intensity": 5, "spot": {}}]}},
  "nodes": [{"mesh": 0, "children": [1, 2, 3]},
            {"translation": [1, 2, 3], "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"translation": [0, 5, 0], "extensions": {"KHR_lights_punctual": {"light": 1}}},
            {"extensions": {"KHR_lights_punctual": {"light": 2}}}],
  "scenes": [{"nodes": [0]}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}],
  "bufferViews": [{"buffer": 0, "byteLength": 36}], "buffers": [{"uri": "t.bin", "byteLength": 36}]})");
  auto r = io::importGltf(gltf);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->lights.size(), 2u); // the spot light is skipped
  EXPECT_EQ(r->lights[0].position, glm::vec3(1, 2, 3));
  EXPECT_EQ(r->lights[0].color, glm::vec3(1, 0.5f, 0.25f));
  EXPECT_FLOAT_EQ(r->lights[0].intensity, 4.0f);
  EXPECT_FLOAT_EQ(r->lights[0].radius, 7.0f);
  EXPECT_EQ(r->lights[1].position, glm::vec3(0, 5, 0));
  EXPECT_FLOAT_EQ(r->lights[1].radius, 100.0f); // no range: where 10 / d^2 falls to 0.001
}

// EXT_meshopt_compression with the octahedral filter (not used by the dream-apartment file): encode with
// meshoptimizer, pack a GLB with a data-less fallback buffer, and check the import reproduces the input.
TEST(ImportGltf, MeshoptOctahedralFilterGlb) {
  auto dir = test::tempDir("gltf-meshopt");
  const float pos[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  const float nrm[4][4] = {{0, 0, 1, 0}, {0, 0, 1, 0}, {0.6f, 0, 0.8f, 0}, {0, -0.6f, 0.8f, 0}};
  const uint16_t idx[6] = {0, 1, 2, 0, 2, 3};
  int8_t oct[4][4];
  meshopt_encodeFilterOct(oct, 4, 4, 8, &nrm[0][0]);
  std::string bin;
  auto append = [&](auto encode, size_t bound) {
    size_t at = bin.size();
    bin.resize(at + bound);
    size_t len = encode(reinterpret_cast<unsigned char*>(&bin[at]), bound);
    bin.resize((at + len + 3) / 4 * 4);
    return std::make_pair(at, len);
  };
  auto p = append([&](unsigned char* d, size_t b) { return meshopt_encodeVertexBuffer(d, b, pos, 4, 12); },
                  meshopt_encodeVertexBufferBound(4, 12));
  auto n = append([&](unsigned char* d, size_t b) { return meshopt_encodeVertexBuffer(d, b, oct, 4, 4); },
                  meshopt_encodeVertexBufferBound(4, 4));
  auto ix = append(
      [&](unsigned char* d, size_t b) {
        unsigned int i32[6];
        std::copy(idx, idx + 6, i32);
        return meshopt_encodeIndexBuffer(d, b, i32, 6);
      },
      meshopt_encodeIndexBufferBound(6, 4));
  std::string json = std::string(R"({"asset": {"version": "2.0"},
  "extensionsUsed": ["EXT_meshopt_compression"], "extensionsRequired": ["EXT_meshopt_compression"],
  "nodes": [{"mesh": 0}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2}]}],
  "accessors": [
    {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]},
    {"bufferView": 1, "componentType": 5120, "normalized": true, "count": 4, "type": "VEC3"},
    {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}],
  "buffers": [{"byteLength": )") +
                     std::to_string(bin.size()) +
                     R"(}, {"byteLength": 76, "extensions": {"EXT_meshopt_compression": {"fallback": true}}}],
  "bufferViews": [)";
  auto view = [](size_t off, size_t len, int stride, int count, const char* mode, const char* filter, size_t fbOff,
                 size_t fbLen, bool vertexStride) {
    std::string v =
        "{\"buffer\": 1, \"byteOffset\": " + std::to_string(fbOff) + ", \"byteLength\": " + std::to_string(fbLen);
    if (vertexStride) v += ", \"byteStride\": " + std::to_string(stride);
    v += ", \"extensions\": {\"EXT_meshopt_compression\": {\"buffer\": 0, \"byteOffset\": " + std::to_string(off) +
         ", \"byteLength\": " + std::to_string(len) + ", \"byteStride\": " + std::to_string(stride) +
         ", \"count\": " + std::to_string(count) + ", \"mode\": \"" + mode + "\", \"filter\": \"" + filter + "\"}}}";
    return v;
  };
  json += view(p.first, p.second, 12, 4, "ATTRIBUTES", "NONE", 0, 48, true) + ",\n";
  json += view(n.first, n.second, 4, 4, "ATTRIBUTES", "OCTAHEDRAL", 48, 16, true) + ",\n";
  json += view(ix.first, ix.second, 2, 6, "TRIANGLES", "NONE", 64, 12, false) + "]}";
  json.resize((json.size() + 3) / 4 * 4, ' ');
  std::string glb = "glTF";
  put<uint32_t>(glb, 2);
  put<uint32_t>(glb, uint32_t(12 + 8 + json.size() + 8 + bin.size()));
  put<uint32_t>(glb, uint32_t(json.size()));
  put<uint32_t>(glb, 0x4E4F534Au);
  glb += json;
  put<uint32_t>(glb, uint32_t(bin.size()));
  put<uint32_t>(glb, 0x004E4942u);
  glb += bin;
  auto file = writeFile(dir / "m.glb", glb);
  io::ImportOptions opt;
  opt.weld = false;
  auto r = io::importGltf(file, opt);
  ASSERT_TRUE(r.ok()) << r.error().message;
  const Mesh& m = r->meshes[0];
  EXPECT_EQ(m.indices, (std::vector<uint32_t>(idx, idx + 6)));
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(m.positions[i], glm::vec3(pos[i][0], pos[i][1], pos[i][2]));
    EXPECT_NEAR(glm::distance(m.normals[i], glm::vec3(nrm[i][0], nrm[i][1], nrm[i][2])), 0.0f, 0.02f) << i;
  }
  // Corrupt the compressed bytes: an Error, not garbage or a crash.
  std::string broken = glb;
  std::fill(broken.end() - long(bin.size()), broken.end(), '\xff');
  auto bad = writeFile(dir / "bad.glb", broken);
  expectError(io::importGltf(bad), bad, "meshopt");
}

TEST(ImportErrors, MissingFileAndUnknownExtension) {
  auto dir = test::tempDir("err-basic");
  for (const char* name : {"none.ply", "none.obj", "none.gltf", "none.glb"})
    expectError(io::importScene(dir / name), dir / name, "not found");
  auto stl = writeFile(dir / "x.stl", "solid x\n");
  expectError(io::importScene(stl), stl, "unknown scene file extension");
}

TEST(ImportErrors, Ply) {
  auto dir = test::tempDir("err-ply");
  auto trunc = writeFile(dir / "trunc.ply", quadPly(false, true));
  expectError(io::importPly(trunc), trunc, "truncated");
  const std::string head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                           "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  auto range = writeFile(dir / "range.ply", head + "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n");
  expectError(io::importPly(range), range, "out of range");
  auto nan = writeFile(dir / "nan.ply", head + "0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n");
  expectError(io::importPly(nan), nan, "non-finite");
  auto two = writeFile(dir / "two.ply", head + "0 0 0\n1 0 0\n0 1 0\n2 0 1\n");
  expectError(io::importPly(two), two, "2 vertices");
  auto shortAscii = writeFile(dir / "short.ply", head + "0 0 0\n1 0 0\n");
  expectError(io::importPly(shortAscii), shortAscii, "truncated");
  auto noFaces = writeFile(dir / "nofaces.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                                                "property float y\nproperty float z\nend_header\n0 0 0\n");
  expectError(io::importPly(noFaces), noFaces, "no triangles: a point cloud of 1 points");
  // Header counts the file cannot hold are rejected before any array is sized by them.
  auto huge = writeFile(dir / "huge.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\n"
                                          "property float x\nproperty float y\nproperty float z\nend_header\n0000");
  expectError(io::importPly(huge), huge, "truncated");
  // The last token may end at end of file without a newline.
  auto noNewline = writeFile(dir / "nonl.ply", head + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2");
  EXPECT_TRUE(io::importPly(noNewline).ok());
  auto garbage = writeFile(dir / "garbage.ply", "\x01\x02garbage");
  expectError(io::importPly(garbage), garbage, "not a PLY");
  // Binary with a negative index (int) must be out of range, not a crash.
  std::string b = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                  "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  for (float f : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) put(b, f);
  b += char(3);
  for (int32_t i : {0, 1, -1}) put(b, i);
  auto neg = writeFile(dir / "neg.ply", b);
  expectError(io::importPly(neg), neg, "out of range");
}

TEST(ImportErrors, Obj) {
  auto dir = test::tempDir("err-obj");
  auto range = writeFile(dir / "range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n");
  expectError(io::importObj(range), range, "line 4");
  auto nan = writeFile(dir / "nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n");
  expectError(io::importObj(nan), nan, "non-finite");
  auto two = writeFile(dir / "two.obj", "v 0 0 0\nv 1 0 0\nf 1 2\n");
  expectError(io::importObj(two), two, "need at least 3");
  auto empty = writeFile(dir / "empty.obj", "# nothing\nv 0 0 0\n");
  expectError(io::importObj(empty), empty, "no triangles");
  auto bad = writeFile(dir / "bad.obj", "v 0 zero 0\n");
  expectError(io::importObj(bad), bad, "bad vertex");
}

TEST(ImportErrors, Gltf) {
  auto dir = test::tempDir("err-gltf");
  auto glb = writeFile(dir / "garbage.glb", std::string("glTF\x02\0\0\0garbage-garbage-garbage", 31));
  expectError(io::importGltf(glb), glb, "");
  auto json = writeFile(dir / "bad.gltf", "{ \"asset\": {\"version\": \"2.0\"}, \"nodes\": [ ");
  expectError(io::importGltf(json), json, "");
  auto noTris = writeFile(dir / "empty.gltf", R"({"asset": {"version": "2.0"}, "scenes": [{"nodes": []}]})");
  expectError(io::importGltf(noTris), noTris, "no triangles");
  // An accessor claiming far more elements than its bufferView holds.
  std::string bin(36, '\0');
  writeFile(dir / "h.bin", bin);
  auto hugeCount = writeFile(dir / "huge.gltf", R"({"asset": {"version": "2.0"}, "nodes": [{"mesh": 0}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4000000000000, "type": "VEC3"}],
  "bufferViews": [{"buffer": 0, "byteLength": 36}], "buffers": [{"uri": "h.bin", "byteLength": 36}]})");
  expectError(io::importGltf(hugeCount), hugeCount, "runs past");
  auto draco = writeFile(dir / "draco.gltf", R"({"asset": {"version": "2.0"},
  "extensionsUsed": ["KHR_draco_mesh_compression"], "extensionsRequired": ["KHR_draco_mesh_compression"]})");
  expectError(io::importGltf(draco), draco, "unsupported glTF extension 'KHR_draco_mesh_compression'");
  auto random = writeFile(dir / "random.glb", std::string(64, '\x7f'));
  expectError(io::importScene(random), random, "");
}

TEST(PlyWrite, RoundTripsThroughTheImporter) {
  mirage::Scene scene = mirage::io::generateScene("blob", 3, 2).value();
  auto dir = mirage::test::tempDir("plywrite");
  auto path = dir / "blob.ply";
  mirage::io::PlyWriteOptions options;
  options.normals = true;
  ASSERT_TRUE(mirage::io::writePly(scene, path, options).ok());
  auto back = mirage::io::importPly(path);
  ASSERT_TRUE(back.ok()) << back.error().message;
  ASSERT_EQ(back->meshTriangleCount(), scene.meshTriangleCount());
  // Positions survive exactly (float32 both ways); welding keeps them in order.
  ASSERT_EQ(back->meshes[0].positions.size(), scene.meshes[0].positions.size());
  for (size_t i = 0; i < scene.meshes[0].positions.size(); i += 97)
    EXPECT_EQ(back->meshes[0].positions[i], scene.meshes[0].positions[i]);
}

TEST(GlbWrite, GeneratedCityRoundTripsThroughTheImporter) {
  mirage::Scene scene = mirage::io::generateScene("city", 7, 1).value();
  auto path = mirage::test::tempDir("glbroundtrip") / "city.glb";
  ASSERT_TRUE(mirage::io::writeGlb(scene, path).ok());
  auto back = mirage::io::importScene(path);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->instances.size(), scene.instances.size());
  EXPECT_EQ(back->instancedTriangleCount(), scene.instancedTriangleCount());
  // The importer keeps only meshes that some node places; count the generator's placed meshes.
  std::set<uint32_t> placed;
  size_t placedTriangles = 0;
  for (const auto& inst : scene.instances)
    if (placed.insert(inst.mesh).second) placedTriangles += scene.meshes[inst.mesh].triangleCount();
  EXPECT_EQ(back->meshTriangleCount(), placedTriangles);
  ASSERT_EQ(back->materials.size(), scene.materials.size());
  for (size_t i = 0; i < scene.materials.size(); ++i) {
    EXPECT_EQ(back->materials[i].alphaMode, scene.materials[i].alphaMode);
    EXPECT_EQ(back->materials[i].doubleSided, scene.materials[i].doubleSided);
    EXPECT_NEAR(back->materials[i].baseColorFactor.r, scene.materials[i].baseColorFactor.r, 1e-6f);
  }
  EXPECT_EQ(back->textures.size(), scene.textures.size());
  mirage::Bounds a = scene.worldBounds(), b = back->worldBounds();
  EXPECT_NEAR(glm::length(a.min - b.min), 0.0f, 1e-3f);
  EXPECT_NEAR(glm::length(a.max - b.max), 0.0f, 1e-3f);
}
