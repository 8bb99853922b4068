// SCEN encoding: exact round trips, validation of everything a decoder must reject, and a
// decoder that survives arbitrary payload bytes (bypassing the container checksums).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>

#include "asset_test_util.h"
#include "mirage/asset/container.h"
#include "mirage/asset/scene_chunk.h"

using namespace mirage;
using namespace mirage::asset;
using namespace mirage::asset::test;

TEST(SceneChunk, EncodeDecodeRoundTripIsExact) {
  Scene s = makeFullScene();
  ASSERT_TRUE(validateScene(s, "x").ok());
  std::vector<uint8_t> bytes = encodeScene(s);
  Result<Scene> back = decodeScene(bytes, "mem");
  ASSERT_TRUE(back.ok()) << back.error().message;
  expectSameScene(*back, s);
  EXPECT_EQ(encodeScene(*back), bytes); // deterministic
}

TEST(SceneChunk, EmptySceneRoundTrips) {
  Scene s;
  Result<Scene> back = decodeScene(encodeScene(s), "mem");
  ASSERT_TRUE(back.ok()) << back.error().message;
  expectSameScene(*back, s);
}

TEST(SceneChunk, SaveLoadRoundTrip) {
  TempDir dir;
  std::string path = dir.file("scene.mrg");
  Scene s = makeFullScene();
  for (int level : {0, 1, 19}) {
    ASSERT_TRUE(saveScene(path, s, level).ok());
    Result<Scene> back = loadScene(path);
    ASSERT_TRUE(back.ok()) << back.error().message;
    expectSameScene(*back, s);
  }
  Result<AssetReader> r = AssetReader::open(path);
  ASSERT_TRUE(r.ok());
  ASSERT_TRUE(r->find(chunk::Meta).has_value());
  std::vector<uint8_t> meta = *r->readChunk(chunk::Meta);
  std::string json(meta.begin(), meta.end());
  EXPECT_NE(json.find("\"formatVersion\": 1"), std::string::npos) << json;
  EXPECT_NE(json.find("\"triangles\": 3"), std::string::npos) << json;
  EXPECT_EQ(dir.list(), std::vector<std::string>{"scene.mrg"});
}

TEST(SceneChunk, InvalidScenesAreRejectedOnSaveAndDecode) {
  struct Case {
    const char* expect;
    std::function<void(Scene&)> patch;
  };
  const float nan = std::nanf("");
  const Case cases[] = {
      {"mesh 0 index 2 = 9 is out of range (4 vertices)", [](Scene& s) { s.meshes[0].indices[2] = 9; }},
      {"not a multiple of 3", [](Scene& s) { s.meshes[0].indices.push_back(0); }},
      {"neither 0 nor the vertex count", [](Scene& s) { s.meshes[0].uv0.pop_back(); }},
      {"neither 0 nor the vertex count", [](Scene& s) { s.meshes[1].tangents.resize(1); }},
      {"uses material 2 (2 materials)", [](Scene& s) { s.meshes[1].material = 2; }},
      {"references texture 2", [](Scene& s) { s.materials[0].normalTexture = 2; }},
      {"references texture -2", [](Scene& s) { s.materials[1].emissiveTexture = -2; }},
      {"position 1 is NaN", [nan](Scene& s) { s.meshes[1].positions[1].y = nan; }},
      {"normal 0 is NaN", [](Scene& s) { s.meshes[0].normals[0].x = INFINITY; }},
      {"color 3 is NaN", [nan](Scene& s) { s.meshes[0].colors[3].w = nan; }},
      {"NaN or infinite factor", [nan](Scene& s) { s.materials[0].roughnessFactor = nan; }},
      {"NaN or infinite transform", [nan](Scene& s) { s.instances[1].transform[2][1] = nan; }},
      {"NaN or infinite bounds", [nan](Scene& s) { s.meshes[0].bounds.max.z = nan; }},
      {"instance 2 uses mesh 5", [](Scene& s) { s.instances[2].mesh = 5; }},
      {"texture 1 has 11 bytes, expected 1x3x4 = 12", [](Scene& s) { s.textures[1].rgba8.pop_back(); }},
      {"alpha mode", [](Scene& s) { s.materials[0].alphaMode = AlphaMode(7); }},
      {"shading model", [](Scene& s) { s.materials[1].model = ShadingModel(5); }},
      {"references texture 3", [](Scene& s) { s.materials[1].detailMaskTexture = 3; }},
      {"NaN or infinite factor", [nan](Scene& s) { s.materials[1].glossiness = nan; }},
      {"NaN or infinite UV transform", [nan](Scene& s) { s.materials[0].uv[kMapNormal].rotation = nan; }},
      {"light 1 has a NaN", [nan](Scene& s) { s.lights[1].position.x = nan; }},
      {"light 0 has radius 0", [](Scene& s) { s.lights[0].radius = 0.0f; }},
      {"light 1 has radius", [](Scene& s) { s.lights[1].intensity = -1.0f; }},
      // 2^31 x 2^31 x 4 bytes wraps to 0 in 64 bits: it matched an empty pixel array.
      {"texture 1 is 2147483648x2147483648: too large",
       [](Scene& s) {
         s.textures[1].width = s.textures[1].height = 1u << 31;
         s.textures[1].rgba8.clear();
       }},
  };
  TempDir dir;
  for (const Case& c : cases) {
    Scene s = makeFullScene();
    c.patch(s);
    Result<Scene> decoded = decodeScene(encodeScene(s), "f.mrg");
    ASSERT_FALSE(decoded.ok()) << c.expect;
    EXPECT_NE(decoded.error().message.find(c.expect), std::string::npos) << decoded.error().message;
    expectOneLineError(decoded.error().message, "f.mrg: SCEN");
    std::string path = dir.file("bad.mrg");
    Status st = saveScene(path, s);
    ASSERT_FALSE(st.ok()) << c.expect;
    EXPECT_NE(st.error().message.find(c.expect), std::string::npos) << st.error().message;
    EXPECT_TRUE(dir.list().empty()) << "an invalid scene must not be written";
  }
}

TEST(SceneChunk, DecodeRejectsVersionTrailingBytesAndEveryTruncation) {
  std::vector<uint8_t> bytes = encodeScene(makeFullScene());
  for (uint8_t v : {0, 3}) {
    std::vector<uint8_t> other = bytes;
    other[0] = v;
    Result<Scene> a = decodeScene(other, "f");
    ASSERT_FALSE(a.ok());
    EXPECT_NE(a.error().message.find("scene chunk version " + std::to_string(v) + " (this build reads 1..2)"),
              std::string::npos)
        << a.error().message;
  }
  std::vector<uint8_t> longer = bytes;
  longer.push_back(0);
  Result<Scene> b = decodeScene(longer, "f");
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.error().message.find("trailing"), std::string::npos);
  for (size_t n = 0; n < bytes.size(); ++n)
    EXPECT_FALSE(decodeScene(std::span(bytes.data(), n), "f").ok()) << "truncated to " << n;
  // Booleans must be 0 or 1: find texture 0's srgb byte (after version, source, count, name, w, h).
  Scene s = makeFullScene();
  size_t at = 1 + 1 + s.source.size() + 1 + 1 + s.textures[0].name.size() + 8;
  ASSERT_EQ(bytes[at], 1);
  std::vector<uint8_t> badBool = bytes;
  badBool[at] = 2;
  Result<Scene> c = decodeScene(badBool, "f");
  ASSERT_FALSE(c.ok());
  EXPECT_NE(c.error().message.find("boolean byte 2"), std::string::npos) << c.error().message;
}

// Version 2 appended fields: a version 1 payload (no material-file fields, no lights) still
// decodes, with those fields at their defaults.
TEST(SceneChunk, VersionOnePayloadDecodes) {
  Scene s = makeFullScene();
  s.materials.clear();
  for (Mesh& m : s.meshes) m.material = 0;
  s.materials.push_back(Material{});
  s.materials[0].name = "plain";
  s.lights.clear();
  std::vector<uint8_t> v2 = encodeScene(s);
  // The v1 layout: the same bytes without the material's version 2 fields and the light count.
  std::vector<uint8_t> v1 = v2;
  v1[0] = 1;
  v1.pop_back(); // light count 0
  // The one material's v2 tail: origin (empty string: 1 byte), model u8, specular 3xf32,
  // glossiness f32, 3 detail textures i32, 8 UV transforms of 5 f32.
  size_t tail = 1 + 1 + 12 + 4 + 12 + kMaterialMapCount * 20;
  // The v1 record ends after name, 4+3+5 f32 factors, alpha mode, double-sided and 5 i32 textures.
  std::string name = s.materials[0].name;
  auto it = std::search(v2.begin(), v2.end(), name.begin(), name.end());
  ASSERT_NE(it, v2.end());
  size_t materialEnd = size_t(it - v2.begin()) + name.size() + 12 * 4 + 2 + 5 * 4;
  v1.erase(v1.begin() + materialEnd, v1.begin() + materialEnd + tail);
  Result<Scene> back = decodeScene(v1, "old.mrg");
  ASSERT_TRUE(back.ok()) << back.error().message;
  expectSameScene(*back, s);
}

TEST(SceneChunk, MetaMustMatchTheScene) {
  TempDir dir;
  std::string path = dir.file("m.mrg");
  Scene s = makeFullScene();
  auto writeWithMeta = [&](const std::string& json) {
    AssetWriter w;
    w.addChunk(chunk::Scene, encodeScene(s));
    w.addChunk(chunk::Meta, std::span(reinterpret_cast<const uint8_t*>(json.data()), json.size()));
    ASSERT_TRUE(w.write(path).ok());
  };
  writeWithMeta(R"({"meshes": 2, "materials": 2, "textures": 2, "instances": 3})");
  EXPECT_TRUE(loadScene(path).ok());
  writeWithMeta(R"({"meshes": 3, "materials": 2, "textures": 2, "instances": 3})");
  Result<Scene> bad = loadScene(path);
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().message, path + ": META meshes does not match the SCEN chunk (2)");
  writeWithMeta("{not json");
  ASSERT_FALSE(loadScene(path).ok());
  EXPECT_NE(loadScene(path).error().message.find("not a JSON object"), std::string::npos);
  AssetWriter w; // no SCEN at all
  w.addChunk(chunk::ClusterDag, std::vector<uint8_t>{1});
  ASSERT_TRUE(w.write(path).ok());
  EXPECT_EQ(loadScene(path).error().message, path + ": no 'SCEN' chunk");
}

TEST(SceneChunk, FuzzDecodeMutatedPayloads) {
  const std::vector<uint8_t> valid = encodeScene(makeFullScene());
  const auto start = std::chrono::steady_clock::now();
  std::mt19937 rng(777);
  int decoded = 0;
  for (int iter = 0; iter < 20000; ++iter) {
    std::vector<uint8_t> bytes = valid;
    if (iter % 10 == 0) { // pure noise
      bytes.resize(rng() % 300);
      for (auto& b : bytes) b = uint8_t(rng());
    } else {
      for (int k = 0, n = 1 + int(rng() % 4); k < n; ++k) {
        size_t at = rng() % bytes.size();
        // Mostly small edits (nearby counts, flipped bits), sometimes huge varint-ish bytes.
        bytes[at] = (rng() % 2) ? uint8_t(bytes[at] ^ (1u << (rng() % 8))) : uint8_t(rng());
      }
    }
    Result<Scene> s = decodeScene(bytes, "fuzz");
    if (s.ok()) {
      ++decoded;
      // Whatever decodes must be a valid scene that re-encodes to the same bytes.
      EXPECT_TRUE(validateScene(*s, "fuzz").ok());
      EXPECT_EQ(encodeScene(*s), bytes);
    }
  }
  EXPECT_GT(decoded, 0); // float edits that stay finite decode fine
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(10));
}
