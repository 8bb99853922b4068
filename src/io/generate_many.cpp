// Many distinct meshes: blob variants scattered over a grid, generated one mesh at a time.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <string>

#include <glm/gtc/matrix_transform.hpp>

#include "generate_common.h"
#include "mirage/io/generate.h"

namespace mirage::io {

namespace {

// Materials the variants cycle through: a few hues, so neighbours differ in a render.
constexpr uint32_t kManyMaterials = 8;

// Per-mesh draws, the same for the layout and the mesh (both derive them from the mesh's index).
struct Variant {
  uint32_t seed;
  float amplitude, frequency;
  uint32_t octaves;
  float scale, angle, jitterX, jitterZ;
};

Variant variant(const ManyOptions& o, uint32_t index) {
  detail::SplitMix64 rng(uint64_t(o.seed) * 0x9E3779B97F4A7C15ull + index);
  Variant v;
  v.seed = uint32_t(rng.next() >> 32) | 1u;
  v.amplitude = rng.range(0.12f, 0.35f);
  v.frequency = rng.range(1.2f, 3.2f);
  v.octaves = 3 + rng.below(4);
  v.scale = rng.range(0.6f, 1.4f);
  v.angle = rng.range(0.0f, 6.2831853f);
  v.jitterX = rng.range(-0.25f, 0.25f);
  v.jitterZ = rng.range(-0.25f, 0.25f);
  return v;
}

uint32_t segmentsFor(uint64_t triangles) {
  double n = std::round(std::sqrt(double(std::max<uint64_t>(triangles, 20)) / 20.0));
  return uint32_t(std::clamp(n, 1.0, 8192.0));
}

} // namespace

Scene generateManyLayout(const ManyOptions& o) {
  Scene scene;
  scene.source = "generated:many";
  for (uint32_t m = 0; m < kManyMaterials; ++m) {
    Material mat;
    mat.name = "many " + std::to_string(m);
    float h = float(m) / float(kManyMaterials);
    glm::vec3 hue =
        glm::clamp(glm::abs(glm::fract(glm::vec3(h) + glm::vec3(0.0f, 2.0f / 3.0f, 1.0f / 3.0f)) * 6.0f - 3.0f) - 1.0f,
                   0.0f, 1.0f);
    mat.baseColorFactor = glm::vec4(glm::mix(glm::vec3(0.75f), hue, 0.45f), 1.0f);
    mat.metallicFactor = 0.0f;
    mat.roughnessFactor = 0.6f;
    scene.materials.push_back(mat);
  }
  // A square grid of side ceil(sqrt(count)), centred on the origin, each blob resting near y = 0.
  uint32_t side = uint32_t(std::ceil(std::sqrt(double(o.count))));
  for (uint32_t i = 0; i < o.count; ++i) {
    Variant v = variant(o, i);
    Mesh mesh;
    mesh.name = "many " + std::to_string(i);
    mesh.material = i % kManyMaterials;
    scene.meshes.push_back(std::move(mesh));
    float x = (float(i % side) - 0.5f * float(side - 1) + v.jitterX) * o.spacing;
    float z = (float(i / side) - 0.5f * float(side - 1) + v.jitterZ) * o.spacing;
    glm::mat4 t = glm::translate(glm::mat4(1.0f), glm::vec3(x, v.scale, z));
    t = glm::rotate(t, v.angle, glm::vec3(0.0f, 1.0f, 0.0f));
    t = glm::scale(t, glm::vec3(v.scale));
    scene.instances.push_back({i, t});
  }
  return scene;
}

Mesh generateManyMesh(const ManyOptions& o, uint32_t index) {
  Variant v = variant(o, index);
  BlobOptions b;
  b.segments = segmentsFor(o.triangles);
  b.amplitude = v.amplitude;
  b.frequency = v.frequency;
  b.octaves = v.octaves;
  b.seed = v.seed;
  Scene blob = generateBlob(b);
  Mesh mesh = std::move(blob.meshes[0]);
  mesh.name = "many " + std::to_string(index);
  mesh.material = index % kManyMaterials;
  return mesh;
}

Scene generateMany(const ManyOptions& o) {
  Scene scene = generateManyLayout(o);
  for (uint32_t i = 0; i < o.count; ++i) scene.meshes[i] = generateManyMesh(o, i);
  return scene;
}

Result<ManyOptions> parseManySize(std::string_view size, uint32_t seed) {
  ManyOptions o;
  o.seed = seed;
  auto bad = [&](const std::string& why) {
    return makeError("generate many", "size '" + std::string(size) + "': " + why);
  };
  auto number = [](std::string_view s, uint64_t& out) {
    auto r = std::from_chars(s.data(), s.data() + s.size(), out);
    return !s.empty() && r.ec == std::errc() && r.ptr == s.data() + s.size();
  };
  if (size.empty() || size == "0") return o;
  size_t x = size.find('x');
  uint64_t count = 0, triangles = o.triangles;
  if (!number(size.substr(0, x), count) || (x != std::string_view::npos && !number(size.substr(x + 1), triangles)))
    return bad("expected COUNT or COUNTxTRIANGLES (e.g. 512x2000000)");
  if (count < 1 || count > 65536) return bad("mesh count out of range (1..65536)");
  if (triangles < 20 || triangles > 1300000000ull) return bad("triangles per mesh out of range (20..1300000000)");
  o.count = uint32_t(count);
  o.triangles = triangles;
  return o;
}

} // namespace mirage::io
