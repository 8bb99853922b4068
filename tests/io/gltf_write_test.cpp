#include <gtest/gtest.h>

#include <cstring>

#include <tiny_gltf.h>

#include "mirage/io/generate.h"
#include "mirage/io/gltf_write.h"
#include "test_support.h"

using namespace mirage;
namespace fs = std::filesystem;

namespace {

// Loads a GLB with tinygltf directly (independent of Mirage's importer).
tinygltf::Model loadWithTinygltf(const fs::path& p) {
  tinygltf::TinyGLTF loader;
  tinygltf::Model model;
  std::string err, warn;
  bool ok = loader.LoadBinaryFromFile(&model, &err, &warn, p.string());
  EXPECT_TRUE(ok) << err;
  EXPECT_TRUE(err.empty()) << err;
  return model;
}

const uint8_t* accessorData(const tinygltf::Model& m, int accessor) {
  const tinygltf::Accessor& a = m.accessors[accessor];
  const tinygltf::BufferView& v = m.bufferViews[a.bufferView];
  return m.buffers[v.buffer].data.data() + v.byteOffset + a.byteOffset;
}

// Checks counts, positions and indices of every mesh and the instance transforms against the scene.
void expectMatches(const Scene& scene, const tinygltf::Model& model) {
  ASSERT_EQ(model.meshes.size(), scene.meshes.size());
  ASSERT_EQ(model.nodes.size(), scene.instances.size());
  ASSERT_EQ(model.materials.size(), scene.materials.size());
  ASSERT_EQ(model.scenes.size(), 1u);
  EXPECT_EQ(model.scenes[0].nodes.size(), scene.instances.size());
  for (size_t i = 0; i < scene.meshes.size(); ++i) {
    const Mesh& mesh = scene.meshes[i];
    ASSERT_EQ(model.meshes[i].primitives.size(), 1u);
    const tinygltf::Primitive& prim = model.meshes[i].primitives[0];
    EXPECT_EQ(prim.mode, TINYGLTF_MODE_TRIANGLES);
    EXPECT_EQ(prim.material, int(mesh.material));
    const tinygltf::Accessor& pos = model.accessors[prim.attributes.at("POSITION")];
    ASSERT_EQ(pos.count, mesh.vertexCount());
    ASSERT_EQ(pos.minValues.size(), 3u);
    EXPECT_FLOAT_EQ(float(pos.minValues[1]), mesh.bounds.min.y);
    EXPECT_FLOAT_EQ(float(pos.maxValues[0]), mesh.bounds.max.x);
    EXPECT_EQ(model.accessors[prim.attributes.at("NORMAL")].count, mesh.vertexCount());
    const tinygltf::Accessor& idx = model.accessors[prim.indices];
    ASSERT_EQ(idx.count, mesh.indices.size());
    EXPECT_EQ(idx.componentType, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT);
    EXPECT_EQ(std::memcmp(accessorData(model, prim.attributes.at("POSITION")), mesh.positions.data(),
                          mesh.positions.size() * 12),
              0);
    EXPECT_EQ(std::memcmp(accessorData(model, prim.indices), mesh.indices.data(), mesh.indices.size() * 4), 0);
  }
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    const tinygltf::Node& node = model.nodes[i];
    EXPECT_EQ(node.mesh, int(scene.instances[i].mesh));
    glm::mat4 m(1.0f);
    if (!node.matrix.empty()) {
      ASSERT_EQ(node.matrix.size(), 16u);
      for (int k = 0; k < 16; ++k) m[k / 4][k % 4] = float(node.matrix[k]);
    }
    EXPECT_EQ(m, scene.instances[i].transform) << "node " << i;
  }
}

} // namespace

TEST(GltfWrite, CityRoundTripsThroughTinygltf) {
  fs::path dir = test::tempDir("glb_city");
  io::CityOptions o;
  o.blocks = 2;
  Scene scene = io::generateCity(o);
  ASSERT_TRUE(io::writeGlb(scene, dir / "city.glb").ok());
  tinygltf::Model model = loadWithTinygltf(dir / "city.glb");
  expectMatches(scene, model);
  // Triangles as a renderer counts them: sum over nodes of their mesh's index count / 3.
  size_t triangles = 0;
  for (const tinygltf::Node& n : model.nodes)
    triangles += model.accessors[model.meshes[n.mesh].primitives[0].indices].count / 3;
  EXPECT_EQ(triangles, scene.instancedTriangleCount());
  // Glass is alpha-blended and double-sided; the paving texture is embedded as PNG and decodes.
  bool glass = false;
  for (const tinygltf::Material& m : model.materials)
    if (m.name == "glass") glass = m.alphaMode == "BLEND" && m.doubleSided;
  EXPECT_TRUE(glass);
  ASSERT_EQ(model.images.size(), 1u);
  EXPECT_EQ(model.images[0].mimeType, "image/png");
  EXPECT_EQ(model.images[0].width, 64);
  EXPECT_EQ(model.images[0].image, scene.textures[0].rgba8);
  ASSERT_EQ(model.textures.size(), 1u);
  EXPECT_EQ(model.materials[scene.meshes[1].material].pbrMetallicRoughness.baseColorTexture.index, 0);
}

TEST(GltfWrite, BlobRoundTripsThroughTinygltf) {
  fs::path dir = test::tempDir("glb_blob");
  io::BlobOptions o;
  o.subdivisions = 4;
  Scene scene = io::generateBlob(o);
  ASSERT_TRUE(io::writeGlb(scene, dir / "blob.glb").ok());
  tinygltf::Model model = loadWithTinygltf(dir / "blob.glb");
  expectMatches(scene, model);
  EXPECT_EQ(model.accessors[model.meshes[0].primitives[0].indices].count / 3, 5120u);
  EXPECT_EQ(model.asset.version, "2.0");
  EXPECT_EQ(fs::file_size(dir / "blob.glb") % 4, 0u);
}

TEST(GltfWrite, MaskMaterialAndEmptyMesh) {
  fs::path dir = test::tempDir("glb_mask");
  Scene scene;
  Material leaf;
  leaf.name = "leaf";
  leaf.alphaMode = AlphaMode::Mask;
  leaf.alphaCutoff = 0.3f;
  scene.materials.push_back(leaf);
  Mesh tri;
  tri.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  tri.normals.assign(3, {0, 0, 1});
  tri.indices = {0, 1, 2};
  scene.meshes.push_back(tri);
  scene.meshes.push_back(Mesh{}); // no triangles: no glTF mesh, its node stays empty
  scene.instances = {{0, glm::mat4(1.0f)}, {1, glm::mat4(2.0f)}};
  ASSERT_TRUE(io::writeGlb(scene, dir / "m.glb").ok());
  tinygltf::Model model = loadWithTinygltf(dir / "m.glb");
  ASSERT_EQ(model.meshes.size(), 1u);
  EXPECT_EQ(model.nodes[1].mesh, -1);
  EXPECT_EQ(model.materials[0].alphaMode, "MASK");
  EXPECT_DOUBLE_EQ(model.materials[0].alphaCutoff, 0.3f);
}

TEST(GltfWrite, MissingDirectoryIsAnError) {
  fs::path dir = test::tempDir("glb_error");
  io::BlobOptions o;
  o.subdivisions = 1;
  Status s = io::writeGlb(io::generateBlob(o), dir / "nope" / "b.glb");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("nope/b.glb: "), std::string::npos);
  EXPECT_TRUE(fs::is_empty(dir));
}
