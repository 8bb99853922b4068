#pragma once
// Small hand-made scenes with known geometry for exact renderer and importer tests.
#include "mirage/core/scene.h"

namespace mirage::test {

// Axis-aligned cube [-h, h]^3, 24 vertices (flat normals), CCW outward faces, UVs per face.
Mesh makeCube(float halfSize = 1.0f, uint32_t material = 0);
// Quad in the XY plane at z, facing +Z (CCW seen from +Z), UVs 0..1.
Mesh makeQuad(float halfSize, float z, uint32_t material = 0);
// The same quad as an n x n grid of quads (2 n^2 triangles): enough for a few clusters when baked.
Mesh makeGrid(float halfSize, float z, uint32_t material = 0, int n = 12);
// UV sphere with `rings` x `segments`, smooth normals.
Mesh makeSphere(float radius, uint32_t rings, uint32_t segments, uint32_t material = 0);
// One instance per mesh, identity transforms, one material per mesh given.
Scene makeScene(std::vector<Mesh> meshes, std::vector<Material> materials);
Material solidMaterial(glm::vec4 color, AlphaMode mode = AlphaMode::Opaque, bool doubleSided = false);
// 8 x 8 checker named "checker": white, alpha 255 / 0 alternating (a glTF MASK cut-out).
Texture checkerCutout();

} // namespace mirage::test
