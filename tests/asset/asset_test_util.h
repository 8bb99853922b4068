#pragma once
// Shared helpers for the asset tests: a scene with every field set, exact scene comparison, a
// per-test temp folder, file bytes in and out, and resealing a patched file's checksums (so a
// test can reach the structural checks that sit behind them).
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>
#include <xxhash.h>

#include "mirage/asset/format.h"
#include "mirage/core/scene.h"

namespace mirage::asset::test {

namespace fs = std::filesystem;

// A fresh folder per test, removed afterwards.
class TempDir {
public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = std::string("mirage-asset-") + std::to_string(::getpid()) + "-" +
                       (info ? std::string(info->test_suite_name()) + "." + info->name() : "x");
    path_ = fs::temp_directory_path() / name;
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  const fs::path& path() const { return path_; }
  // Names of everything in the folder, sorted.
  std::vector<std::string> list() const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(path_)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }

private:
  fs::path path_;
};

// `n` bytes of a seeded generator, each one of `symbols` values (fewer: more compressible).
inline std::vector<uint8_t> randomBytes(size_t n, uint32_t seed, uint32_t symbols = 256) {
  std::mt19937 rng(seed);
  std::vector<uint8_t> v(n);
  for (auto& b : v) b = uint8_t(rng() % symbols);
  return v;
}

inline std::vector<uint8_t> readBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), {});
}

inline void writeBytes(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

inline FileHeader header(const std::vector<uint8_t>& file) {
  FileHeader h{};
  std::memcpy(&h, file.data(), sizeof(h));
  return h;
}

inline ChunkEntry entry(const std::vector<uint8_t>& file, size_t i) {
  ChunkEntry e{};
  std::memcpy(&e, file.data() + header(file).tableOffset + i * sizeof(ChunkEntry), sizeof(e));
  return e;
}

inline void setEntry(std::vector<uint8_t>& file, size_t i, const ChunkEntry& e) {
  std::memcpy(file.data() + header(file).tableOffset + i * sizeof(ChunkEntry), &e, sizeof(e));
}

inline void setHeader(std::vector<uint8_t>& file, const FileHeader& h) { std::memcpy(file.data(), &h, sizeof(h)); }

// Recompute the table and header checksums after a test patched either (when the table lies
// inside the file), so the reader gets past the checksums to the check under test.
inline void reseal(std::vector<uint8_t>& file) {
  if (file.size() < sizeof(FileHeader)) return;
  FileHeader h = header(file);
  uint64_t tableBytes = uint64_t(h.chunkCount) * sizeof(ChunkEntry);
  if (h.tableOffset <= file.size() && tableBytes <= file.size() - h.tableOffset)
    h.tableHash = XXH3_64bits(file.data() + h.tableOffset, tableBytes);
  h.headerHash = XXH3_64bits(&h, offsetof(FileHeader, headerHash));
  setHeader(file, h);
}

// Every Scene field set to a non-default value, two meshes (one with all attributes, one with
// the minimum), two textures, two materials, three instances.
inline Scene makeFullScene() {
  Scene s;
  s.source = "test:full-scene ü";
  Texture t0{"albedo.png", 2, 2, {}, true};
  for (int i = 0; i < 16; ++i) t0.rgba8.push_back(uint8_t(i * 13 + 7));
  Texture t1{"embedded #1", 1, 3, {}, false};
  for (int i = 0; i < 12; ++i) t1.rgba8.push_back(uint8_t(255 - i * 11));
  s.textures = {t0, t1};

  Material m0;
  m0.name = "painted metal";
  m0.baseColorFactor = {0.8f, 0.5f, 0.25f, 0.75f};
  m0.emissiveFactor = {0.1f, 0.2f, 0.3f};
  m0.metallicFactor = 0.3f;
  m0.roughnessFactor = 0.6f;
  m0.normalScale = 0.9f;
  m0.occlusionStrength = 0.7f;
  m0.alphaCutoff = 0.33f;
  m0.alphaMode = AlphaMode::Mask;
  m0.doubleSided = true;
  m0.baseColorTexture = 0;
  m0.metallicRoughnessTexture = 1;
  m0.normalTexture = 1;
  m0.occlusionTexture = 0;
  m0.emissiveTexture = 0;
  Material m1;
  m1.name = "glass";
  m1.origin = "mats.toml:12";
  m1.alphaMode = AlphaMode::Blend;
  m1.model = ShadingModel::BlinnPhong;
  m1.specularColor = {0.5f, 0.25f, 0.125f};
  m1.glossiness = 0.75f;
  m1.detailAlbedoTexture = 0;
  m1.detailNormalTexture = 1;
  m1.detailMaskTexture = 0;
  m1.uv[kMapDetailNormal] = {{0.5f, -0.25f}, {4.0f, 2.0f}, 0.3f};
  s.materials = {m0, m1};

  Mesh a;
  a.name = "quad";
  a.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  a.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
  a.tangents = {{1, 0, 0, 1}, {1, 0, 0, -1}, {1, 0, 0, 1}, {1, 0, 0, 1}};
  a.uv0 = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  a.colors = {{1, 0, 0, 1}, {0, 1, 0, 1}, {0, 0, 1, 0.5f}, {1, 1, 1, 1}};
  a.indices = {0, 1, 2, 0, 2, 3};
  a.material = 0;
  for (auto p : a.positions) a.bounds.add(p);
  Mesh b;
  b.name = "triangle";
  b.positions = {{-1, 0, 2}, {1, 0.5f, 2}, {0, 3, -2.5f}};
  b.normals = {{0, 1, 0}, {0, 1, 0}, {0, 1, 0}};
  b.indices = {0, 2, 1};
  b.material = 1;
  for (auto p : b.positions) b.bounds.add(p);
  s.meshes = {a, b};

  glm::mat4 t(1.0f);
  t[3] = {5, -2, 1.5f, 1};
  glm::mat4 r(0.0f);
  r[0] = {0, 1, 0, 0};
  r[1] = {-1, 0, 0, 0};
  r[2] = {0, 0, 2, 0};
  r[3] = {0.25f, 0, 0, 1};
  s.instances = {{0, glm::mat4(1.0f)}, {1, t}, {0, r}};
  s.lights = {{{1, 2, 3}, {1, 0.5f, 0.25f}, 4.0f, 7.5f}, {{-1, 0, 0}, {0, 1, 0}, 0.0f, 0.01f}};
  return s;
}

// Field-by-field exact comparison (bitwise for floats: a round trip must not change anything).
inline void expectSameScene(const Scene& a, const Scene& b) {
  EXPECT_EQ(a.source, b.source);
  ASSERT_EQ(a.textures.size(), b.textures.size());
  for (size_t i = 0; i < a.textures.size(); ++i) {
    const Texture &x = a.textures[i], &y = b.textures[i];
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.width, y.width);
    EXPECT_EQ(x.height, y.height);
    EXPECT_EQ(x.rgba8, y.rgba8);
    EXPECT_EQ(x.srgb, y.srgb);
  }
  ASSERT_EQ(a.materials.size(), b.materials.size());
  for (size_t i = 0; i < a.materials.size(); ++i) {
    const Material &x = a.materials[i], &y = b.materials[i];
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.baseColorFactor, y.baseColorFactor);
    EXPECT_EQ(x.emissiveFactor, y.emissiveFactor);
    EXPECT_EQ(x.metallicFactor, y.metallicFactor);
    EXPECT_EQ(x.roughnessFactor, y.roughnessFactor);
    EXPECT_EQ(x.normalScale, y.normalScale);
    EXPECT_EQ(x.occlusionStrength, y.occlusionStrength);
    EXPECT_EQ(x.alphaCutoff, y.alphaCutoff);
    EXPECT_EQ(x.alphaMode, y.alphaMode);
    EXPECT_EQ(x.doubleSided, y.doubleSided);
    EXPECT_EQ(x.baseColorTexture, y.baseColorTexture);
    EXPECT_EQ(x.metallicRoughnessTexture, y.metallicRoughnessTexture);
    EXPECT_EQ(x.normalTexture, y.normalTexture);
    EXPECT_EQ(x.occlusionTexture, y.occlusionTexture);
    EXPECT_EQ(x.emissiveTexture, y.emissiveTexture);
    EXPECT_EQ(x.origin, y.origin);
    EXPECT_EQ(x.model, y.model);
    EXPECT_EQ(x.specularColor, y.specularColor);
    EXPECT_EQ(x.glossiness, y.glossiness);
    EXPECT_EQ(x.detailAlbedoTexture, y.detailAlbedoTexture);
    EXPECT_EQ(x.detailNormalTexture, y.detailNormalTexture);
    EXPECT_EQ(x.detailMaskTexture, y.detailMaskTexture);
    for (int k = 0; k < kMaterialMapCount; ++k) {
      EXPECT_EQ(x.uv[k].offset, y.uv[k].offset);
      EXPECT_EQ(x.uv[k].scale, y.uv[k].scale);
      EXPECT_EQ(x.uv[k].rotation, y.uv[k].rotation);
    }
  }
  ASSERT_EQ(a.lights.size(), b.lights.size());
  for (size_t i = 0; i < a.lights.size(); ++i) {
    EXPECT_EQ(a.lights[i].position, b.lights[i].position);
    EXPECT_EQ(a.lights[i].color, b.lights[i].color);
    EXPECT_EQ(a.lights[i].intensity, b.lights[i].intensity);
    EXPECT_EQ(a.lights[i].radius, b.lights[i].radius);
  }
  ASSERT_EQ(a.meshes.size(), b.meshes.size());
  for (size_t i = 0; i < a.meshes.size(); ++i) {
    const Mesh &x = a.meshes[i], &y = b.meshes[i];
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.positions, y.positions);
    EXPECT_EQ(x.normals, y.normals);
    EXPECT_EQ(x.tangents, y.tangents);
    EXPECT_EQ(x.uv0, y.uv0);
    EXPECT_EQ(x.colors, y.colors);
    EXPECT_EQ(x.indices, y.indices);
    EXPECT_EQ(x.material, y.material);
    EXPECT_EQ(x.bounds.min, y.bounds.min);
    EXPECT_EQ(x.bounds.max, y.bounds.max);
  }
  ASSERT_EQ(a.instances.size(), b.instances.size());
  for (size_t i = 0; i < a.instances.size(); ++i) {
    EXPECT_EQ(a.instances[i].mesh, b.instances[i].mesh);
    EXPECT_EQ(a.instances[i].transform, b.instances[i].transform);
  }
}

// Whether `part` occurs in `s` (error messages name what they refuse).
inline bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

// An error is one line naming the file.
inline void expectOneLineError(const std::string& message, const std::string& file) {
  EXPECT_EQ(message.rfind(file + ": ", 0), 0u) << message;
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
}

} // namespace mirage::asset::test
