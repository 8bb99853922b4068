// Imports every model in ../shared/data and checks counts, materials and the meshopt decoder against real files.
#include <gtest/gtest.h>

#include <cmath>

#include "mirage/io/import.h"
#include "support/test_support.h"

using namespace mirage;

namespace {

Scene importChecked(const std::filesystem::path& p, io::ImportOptions opt = {}) {
  auto r = io::importScene(p, opt);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  if (!r.ok()) return {};
  Scene s = std::move(r).value();
  // Invariants every import must hold.
  EXPECT_FALSE(s.materials.empty());
  EXPECT_FALSE(s.instances.empty());
  for (const Mesh& m : s.meshes) {
    EXPECT_EQ(m.normals.size(), m.positions.size());
    EXPECT_LT(m.material, s.materials.size());
    EXPECT_FALSE(m.bounds.empty());
  }
  return s;
}

struct Count {
  const char* file;
  size_t triangles; // instanced triangles after import
};

// README counts. All files import with exactly the README triangle count: importers keep degenerate triangles
// (they drop nothing), and the glTF files place each mesh once, so instanced == README.
const Count kCounts[] = {
    {"stanford-bunny/bun_zipper.ply", 69451},
    {"stanford-dragon/dragon_vrip_res2.ply", 202520},
    {"stanford-dragon/dragon_vrip_res3.ply", 47794},
    {"stanford-dragon/dragon_vrip_res4.ply", 11102},
    {"cyberware-horse/horse.ply", 96966},
    {"khronos-damaged-helmet/DamagedHelmet.glb", 15452},
    {"khronos-flight-helmet/glTF/FlightHelmet.gltf", 94722},
    {"khronos-alpha-blend-mode-test/glTF/AlphaBlendModeTest.gltf", 61},
    {"khronos-suzanne/glTF/Suzanne.gltf", 3936},
    {"dabrovic-sponza/gltf/sponza.gltf", 66454},
    {"dream-apartment/dream-apartment.glb", 177934},
    {"dream-apartment/dream-apartment.meshopt.glb", 177934},
    {"openarena-maps/obj/oasago2.obj", 41167},
    {"openarena-maps/obj/czest2ctf.obj", 37320},
};

} // namespace

TEST(ImportData, TriangleCountsMatchReadme) {
  io::ImportOptions opt;
  opt.loadTextures = false; // counts only; texture decoding is covered below
  for (const Count& c : kCounts) {
    SCOPED_TRACE(c.file);
    MIRAGE_REQUIRE_DATA(path, c.file);
    Scene s = importChecked(path, opt);
    EXPECT_EQ(s.instancedTriangleCount(), c.triangles);
  }
}

TEST(ImportData, DragonFullResolution) {
  MIRAGE_REQUIRE_DATA(path, "stanford-dragon/dragon_vrip.ply");
  Scene s = importChecked(path);
  EXPECT_EQ(s.instancedTriangleCount(), 871414u);
  ASSERT_EQ(s.meshes.size(), 1u);
  EXPECT_LE(s.meshes[0].vertexCount(), 437645u); // welding may only merge
}

TEST(ImportData, HorseKeepsFileNormals) {
  MIRAGE_REQUIRE_DATA(path, "cyberware-horse/horse.ply");
  io::ImportOptions opt;
  opt.weld = false;
  Scene s = importChecked(path, opt);
  ASSERT_EQ(s.meshes.size(), 1u);
  EXPECT_EQ(s.meshes[0].vertexCount(), 48485u);
  // The file stores unnormalised (area-weighted) normals; the importer keeps their direction at unit length.
  for (const glm::vec3& n : s.meshes[0].normals) ASSERT_NEAR(glm::length(n), 1.0f, 1e-5f);
  glm::vec3 first{1.7324599f, -1.2141895f, 6.2491121f}; // vertex 0's normal as stored in horse.ply
  EXPECT_NEAR(glm::distance(s.meshes[0].normals[0], glm::normalize(first)), 0.0f, 1e-5f);
}

TEST(ImportData, AlphaBlendModes) {
  MIRAGE_REQUIRE_DATA(path, "khronos-alpha-blend-mode-test/glTF/AlphaBlendModeTest.gltf");
  Scene s = importChecked(path);
  int opaque = 0, blend = 0, mask = 0;
  bool explicitCutoff = false;
  for (const Material& m : s.materials) {
    opaque += m.alphaMode == AlphaMode::Opaque;
    blend += m.alphaMode == AlphaMode::Blend;
    mask += m.alphaMode == AlphaMode::Mask;
    if (m.alphaMode == AlphaMode::Mask && std::fabs(m.alphaCutoff - 0.5f) > 1e-3f) explicitCutoff = true;
  }
  EXPECT_EQ(opaque, 2);
  EXPECT_EQ(blend, 1);
  EXPECT_EQ(mask, 3);
  EXPECT_TRUE(explicitCutoff);
}

TEST(ImportData, FlightHelmetLensesBlend) {
  MIRAGE_REQUIRE_DATA(path, "khronos-flight-helmet/glTF/FlightHelmet.gltf");
  Scene s = importChecked(path);
  EXPECT_EQ(s.materials.size(), 6u);
  bool lensesBlend = false;
  for (const Material& m : s.materials)
    if (m.name == "LensesMat") lensesBlend = m.alphaMode == AlphaMode::Blend;
  EXPECT_TRUE(lensesBlend);
  EXPECT_EQ(s.textures.size(), 15u);
  int full = 0; // Bevy's copies are 512^2, except the tiny flat LensesMat normal map
  for (const Texture& t : s.textures) {
    full += t.width == 512u && t.height == 512u;
    EXPECT_GT(t.width, 0u);
    EXPECT_EQ(t.rgba8.size(), size_t(t.width) * t.height * 4);
  }
  EXPECT_GE(full, 14);
  EXPECT_GT(s.instances.size(), 1u); // several nodes place several meshes
}

TEST(ImportData, DamagedHelmetHasAllTextures) {
  MIRAGE_REQUIRE_DATA(path, "khronos-damaged-helmet/DamagedHelmet.glb");
  Scene s = importChecked(path);
  ASSERT_EQ(s.materials.size(), 1u);
  const Material& m = s.materials[0];
  for (int t :
       {m.baseColorTexture, m.metallicRoughnessTexture, m.normalTexture, m.occlusionTexture, m.emissiveTexture}) {
    ASSERT_GE(t, 0);
    ASSERT_LT(size_t(t), s.textures.size());
    EXPECT_GT(s.textures[t].width, 0u);
  }
  EXPECT_TRUE(s.textures[m.baseColorTexture].srgb);
  EXPECT_TRUE(s.textures[m.emissiveTexture].srgb);
  EXPECT_FALSE(s.textures[m.normalTexture].srgb);
  EXPECT_FALSE(s.textures[m.metallicRoughnessTexture].srgb);
  ASSERT_EQ(s.meshes.size(), 1u);
  EXPECT_EQ(s.meshes[0].uv0.size(), s.meshes[0].vertexCount());
}

// The meshopt-compressed file must decode to the same geometry as the plain copy glTF-Transform decoded.
TEST(ImportData, MeshoptMatchesPlain) {
  MIRAGE_REQUIRE_DATA(plainPath, "dream-apartment/dream-apartment.glb");
  MIRAGE_REQUIRE_DATA(packedPath, "dream-apartment/dream-apartment.meshopt.glb");
  io::ImportOptions opt;
  opt.weld = false; // compare vertex for vertex
  Scene plain = importChecked(plainPath, opt), packed = importChecked(packedPath, opt);
  ASSERT_EQ(plain.meshes.size(), packed.meshes.size());
  EXPECT_EQ(plain.instancedTriangleCount(), 177934u);
  EXPECT_EQ(packed.instancedTriangleCount(), plain.instancedTriangleCount());
  ASSERT_EQ(plain.instances.size(), packed.instances.size());
  EXPECT_EQ(packed.materials.size(), 67u);
  for (size_t i = 0; i < plain.meshes.size(); ++i) {
    const Mesh &a = plain.meshes[i], &b = packed.meshes[i];
    ASSERT_EQ(a.indices, b.indices) << "mesh " << i;
    ASSERT_EQ(a.positions.size(), b.positions.size());
    float tol = 1e-4f * std::max(1.0f, a.bounds.radius());
    for (size_t v = 0; v < a.positions.size(); ++v)
      ASSERT_LE(glm::length(a.positions[v] - b.positions[v]), tol) << "mesh " << i << " vertex " << v;
  }
  for (size_t i = 0; i < plain.instances.size(); ++i)
    for (int c = 0; c < 4; ++c)
      EXPECT_LE(glm::length(plain.instances[i].transform[c] - packed.instances[i].transform[c]), 1e-4f);
  Bounds pb = plain.worldBounds(), kb = packed.worldBounds();
  EXPECT_LE(glm::length(pb.min - kb.min), 1e-3f);
  EXPECT_LE(glm::length(pb.max - kb.max), 1e-3f);
}
