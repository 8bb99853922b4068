// City: a street grid of blocks, each split into lots holding instances of a few building variants.
// Buildings are real geometry rather than textured boxes so occlusion culling and LOD have work to
// do: thick facade walls with recessed windows (reveals, glass panes), ledges, roofs, and interiors
// with floor slabs and partition walls with door openings.
#include <algorithm>
#include <cmath>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "generate_common.h"
#include "mirage/io/generate.h"

namespace mirage::io {

namespace {

// Material slots, in Scene::materials order.
enum MaterialSlot : uint32_t { kAsphalt, kSidewalk, kBrick, kConcrete, kSandstone, kGlass, kPlaster, kMaterialCount };

constexpr float kLot = 30.0f;    // lot side in metres
constexpr float kStreet = 16.0f; // street width between blocks
constexpr float kCurb = 0.15f;   // sidewalk slab height; buildings stand on it
constexpr float kWall = 0.3f;    // exterior wall thickness
constexpr float kPartition = 0.15f;
constexpr float kSlab = 0.25f; // floor slab thickness

// Appends flat-shaded quads. Each quad gets its own 4 vertices (hard edges everywhere, as buildings
// have) and planar UVs in metres / 2 so tiling textures line up with the geometry.
struct QuadBuilder {
  Mesh& mesh;
  // Corners in order around the quad; winding is flipped if needed so the face points along `facing`.
  void quad(glm::vec3 p0, glm::vec3 p1, glm::vec3 p2, glm::vec3 p3, glm::vec3 facing) {
    glm::vec3 n = glm::cross(p1 - p0, p3 - p0);
    float len = glm::length(n);
    if (len < 1e-9f) return; // degenerate strip (zero width): nothing to draw
    n /= len;
    if (glm::dot(n, facing) < 0.0f) {
      std::swap(p1, p3);
      n = -n;
    }
    uint32_t base = uint32_t(mesh.positions.size());
    float u = glm::length(p1 - p0) * 0.5f, v = glm::length(p3 - p0) * 0.5f;
    mesh.positions.insert(mesh.positions.end(), {p0, p1, p2, p3});
    mesh.normals.insert(mesh.normals.end(), 4, n);
    mesh.uv0.insert(mesh.uv0.end(), {{0, 0}, {u, 0}, {u, v}, {0, v}});
    mesh.indices.insert(mesh.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
  }
  // Axis-aligned box; `faces` bit k skips face k (0:-x 1:+x 2:-y 3:+y 4:-z 5:+z) when set.
  void box(glm::vec3 lo, glm::vec3 hi, uint32_t skip = 0) {
    auto c = [&](int x, int y, int z) { return glm::vec3(x ? hi.x : lo.x, y ? hi.y : lo.y, z ? hi.z : lo.z); };
    if (!(skip & 1)) quad(c(0, 0, 0), c(0, 0, 1), c(0, 1, 1), c(0, 1, 0), {-1, 0, 0});
    if (!(skip & 2)) quad(c(1, 0, 0), c(1, 0, 1), c(1, 1, 1), c(1, 1, 0), {1, 0, 0});
    if (!(skip & 4)) quad(c(0, 0, 0), c(1, 0, 0), c(1, 0, 1), c(0, 0, 1), {0, -1, 0});
    if (!(skip & 8)) quad(c(0, 1, 0), c(1, 1, 0), c(1, 1, 1), c(0, 1, 1), {0, 1, 0});
    if (!(skip & 16)) quad(c(0, 0, 0), c(1, 0, 0), c(1, 1, 0), c(0, 1, 0), {0, 0, -1});
    if (!(skip & 32)) quad(c(0, 0, 1), c(1, 0, 1), c(1, 1, 1), c(0, 1, 1), {0, 0, 1});
  }
};

// A wall plane: local x along `right`, y up, depth d measured inward (against `out`).
struct Frame {
  glm::vec3 origin, right, out;
  glm::vec3 at(float x, float y, float d) const { return origin + right * x + glm::vec3(0, y, 0) - out * d; }
};

struct Hole {
  float x0, x1, y0, y1;
};

// One face of a wall band [y0, y1] spanning [xa, xb] at depth d, with rectangular holes (sorted by x,
// not overlapping) cut out: columns between holes plus strips below and above each hole.
void faceWithHoles(QuadBuilder& b, const Frame& f, float xa, float xb, float y0, float y1, float d,
                   const std::vector<Hole>& holes, glm::vec3 facing) {
  auto rect = [&](float x0, float x1, float ya, float yb) {
    if (x1 - x0 > 1e-4f && yb - ya > 1e-4f)
      b.quad(f.at(x0, ya, d), f.at(x1, ya, d), f.at(x1, yb, d), f.at(x0, yb, d), facing);
  };
  float x = xa;
  for (const Hole& h : holes) {
    rect(x, h.x0, y0, y1);
    rect(h.x0, h.x1, y0, h.y0);
    rect(h.x0, h.x1, h.y1, y1);
    x = h.x1;
  }
  rect(x, xb, y0, y1);
}

// A wall of thickness t: outer face over [xa, xb], inner face over [ia, ib] (exterior walls trim the
// inner face at the corners), and the reveals lining each hole. Window holes get a glass pane.
void wallWithHoles(QuadBuilder& shell, QuadBuilder* glass, const Frame& f, float xa, float xb, float ia, float ib,
                   float y0, float y1, float t, const std::vector<Hole>& holes) {
  faceWithHoles(shell, f, xa, xb, y0, y1, 0.0f, holes, f.out);
  faceWithHoles(shell, f, ia, ib, y0, y1, t, holes, -f.out);
  glm::vec3 up(0, 1, 0);
  for (const Hole& h : holes) {
    shell.quad(f.at(h.x0, h.y0, 0), f.at(h.x0, h.y0, t), f.at(h.x0, h.y1, t), f.at(h.x0, h.y1, 0), f.right);
    shell.quad(f.at(h.x1, h.y0, 0), f.at(h.x1, h.y0, t), f.at(h.x1, h.y1, t), f.at(h.x1, h.y1, 0), -f.right);
    shell.quad(f.at(h.x0, h.y1, 0), f.at(h.x1, h.y1, 0), f.at(h.x1, h.y1, t), f.at(h.x0, h.y1, t), -up);
    if (h.y0 > y0) shell.quad(f.at(h.x0, h.y0, 0), f.at(h.x1, h.y0, 0), f.at(h.x1, h.y0, t), f.at(h.x0, h.y0, t), up);
    if (glass) {
      float d = t * 0.6f; // recessed: the reveal shows in front of the pane
      glass->quad(f.at(h.x0, h.y0, d), f.at(h.x1, h.y0, d), f.at(h.x1, h.y1, d), f.at(h.x0, h.y1, d), f.out);
    }
  }
}

struct Variant {
  float width, depth, floorHeight, bay;
  uint32_t floors, facade;
};

// Builds one building variant as three meshes (shell, glass, interior), centred on the origin
// in XZ with its ground floor at y = 0.
void buildVariant(const Variant& v, bool interiors, Mesh& shellMesh, Mesh& glassMesh, Mesh& interiorMesh) {
  QuadBuilder shell{shellMesh}, glass{glassMesh}, inside{interiorMesh};
  const float hw = v.width * 0.5f, hd = v.depth * 0.5f, top = v.floors * v.floorHeight;
  const Frame facades[4] = {{{-hw, 0, hd}, {1, 0, 0}, {0, 0, 1}},
                            {{hw, 0, hd}, {0, 0, -1}, {1, 0, 0}},
                            {{hw, 0, -hd}, {-1, 0, 0}, {0, 0, -1}},
                            {{-hw, 0, -hd}, {0, 0, 1}, {-1, 0, 0}}};
  const float lengths[4] = {v.width, v.depth, v.width, v.depth};

  for (int side = 0; side < 4; ++side) {
    const Frame& f = facades[side];
    const float len = lengths[side], margin = 1.0f;
    const uint32_t bays = std::max(1u, uint32_t((len - 2 * margin) / v.bay));
    const float bay = (len - 2 * margin) / float(bays);
    for (uint32_t floor = 0; floor < v.floors; ++floor) {
      const float y0 = floor * v.floorHeight, y1 = y0 + v.floorHeight;
      std::vector<Hole> holes;
      for (uint32_t k = 0; k < bays; ++k) {
        float cx = margin + (float(k) + 0.5f) * bay, ww = bay * 0.55f;
        // The middle bay of the ground floor's front is a door, so the lobby opens to the street.
        bool door = floor == 0 && side == 0 && k == bays / 2;
        float sill = door ? 0.0f : 0.9f, height = door ? 2.4f : v.floorHeight * 0.5f;
        holes.push_back({cx - ww * 0.5f, cx + ww * 0.5f, y0 + sill, y0 + sill + height});
      }
      wallWithHoles(shell, &glass, f, 0.0f, len, kWall, len - kWall, y0, y1, kWall, holes);
      // Ledge (a string course) at every floor line above the ground floor.
      if (floor > 0) {
        float p = 0.15f, ya = y0 - 0.1f, yb = y0 + 0.1f;
        shell.quad(f.at(0, ya, -p), f.at(len, ya, -p), f.at(len, yb, -p), f.at(0, yb, -p), f.out);
        shell.quad(f.at(0, yb, -p), f.at(len, yb, -p), f.at(len, yb, 0), f.at(0, yb, 0), {0, 1, 0});
        shell.quad(f.at(0, ya, -p), f.at(len, ya, -p), f.at(len, ya, 0), f.at(0, ya, 0), {0, -1, 0});
      }
    }
    // Top of the wall, so the shell reads as solid from above.
    shell.quad(f.at(0, top, 0), f.at(len, top, 0), f.at(len, top, kWall), f.at(0, top, kWall), {0, 1, 0});
  }
  // Roof slab over the interior; its underside is the top floor's ceiling.
  const glm::vec3 lo(-hw + kWall, top - kSlab, -hd + kWall), hi(hw - kWall, top, hd - kWall);
  shell.box(lo, hi, 1 | 2 | 16 | 32);
  // A roof-top plant room: a small closed box breaking the silhouette.
  shell.box({-hw * 0.3f, top, -hd * 0.3f}, {hw * 0.2f, top + 2.5f, hd * 0.1f}, 4);

  if (!interiors) return;
  for (uint32_t floor = 0; floor < v.floors; ++floor) {
    const float y0 = floor * v.floorHeight, y1 = y0 + v.floorHeight - (floor + 1 == v.floors ? kSlab : 0.0f);
    // Floor slab (top face is the floor, bottom face the ceiling of the storey below).
    inside.box({-hw + kWall, y0 - (floor ? kSlab : 0.0f), -hd + kWall}, {hw - kWall, y0, hd - kWall},
               1 | 2 | 16 | 32 | (floor ? 0 : 4));
    // Two partition walls crossing the storey, each with a door that alternates sides by floor so
    // sight lines through the building are short.
    float doorX = (floor % 2 ? 0.25f : 0.65f), doorW = 1.0f;
    {
      Frame f{{-hw + kWall, 0, kPartition * 0.5f}, {1, 0, 0}, {0, 0, 1}};
      float len = v.width - 2 * kWall, x = doorX * len;
      wallWithHoles(inside, nullptr, f, 0, len, 0, len, y0, y1, kPartition, {{x, x + doorW, y0, y0 + 2.1f}});
    }
    {
      Frame f{{kPartition * 0.5f, 0, hd - kWall}, {0, 0, -1}, {1, 0, 0}};
      float len = v.depth - 2 * kWall, x = (1.0f - doorX) * len - doorW;
      wallWithHoles(inside, nullptr, f, 0, len, 0, len, y0, y1, kPartition, {{x, x + doorW, y0, y0 + 2.1f}});
    }
  }
}

Material material(const char* name, glm::vec4 color, float roughness) {
  Material m;
  m.name = name;
  m.baseColorFactor = color;
  m.metallicFactor = 0.0f;
  m.roughnessFactor = roughness;
  return m;
}

// 64×64 paving-slab texture for the sidewalks (exercises texture paths in exporters and renderers).
Texture pavingTexture(uint32_t seed) {
  Texture t;
  t.name = "paving";
  t.width = t.height = 64;
  t.rgba8.resize(64 * 64 * 4);
  detail::SplitMix64 rng(seed * 7919u + 13u);
  for (uint32_t y = 0; y < 64; ++y)
    for (uint32_t x = 0; x < 64; ++x) {
      bool joint = x % 32 == 0 || y % 32 == 0;
      int v = joint ? 90 : 160 + int(rng.below(24));
      uint8_t* p = &t.rgba8[(y * 64 + x) * 4];
      p[0] = uint8_t(v), p[1] = uint8_t(v), p[2] = uint8_t(v - 6), p[3] = 255;
    }
  return t;
}

} // namespace

// The street layout generateCity builds on: blocks of lots, streets between them and a street's
// width of ground around the grid, centred on the origin.
struct StreetGrid {
  uint32_t blocks;
  float pitch, extent, origin;
  explicit StreetGrid(const CityOptions& options) {
    blocks = std::clamp<uint32_t>(options.blocks, 1, 256);
    const float blockSize = float(std::clamp<uint32_t>(options.lotsPerBlockSide, 1, 8)) * kLot;
    pitch = blockSize + kStreet;
    extent = float(blocks) * pitch - kStreet;
    origin = -0.5f * extent;
  }
  // Centre line of street i (0..blocks): before block i, the first and last around the grid.
  float street(uint32_t i) const { return origin + float(i) * pitch - 0.5f * kStreet; }
};

std::vector<Bounds> cityStreetCells(const CityOptions& options, uint32_t perStreet) {
  const StreetGrid g(options);
  const float half = 2.0f, lo = 0.7f, hi = 2.7f;
  const float from = g.street(0), to = g.street(g.blocks); // the streets around the grid meet there
  std::vector<Bounds> cells;
  cells.reserve(size_t(g.blocks + 1) * 2 * perStreet);
  for (int axis = 0; axis < 2; ++axis)
    for (uint32_t i = 0; i <= g.blocks; ++i)
      for (uint32_t k = 0; k < perStreet; ++k) {
        float along = from + (to - from) * (float(k) + 0.5f) / float(perStreet), across = g.street(i);
        glm::vec3 c = axis == 0 ? glm::vec3(along, 0.0f, across) : glm::vec3(across, 0.0f, along);
        Bounds b;
        b.add({c.x - half, lo, c.z - half});
        b.add({c.x + half, hi, c.z + half});
        cells.push_back(b);
      }
  return cells;
}

Scene generateCity(const CityOptions& options) {
  const uint32_t blocks = std::clamp<uint32_t>(options.blocks, 1, 256);
  const uint32_t lots = std::clamp<uint32_t>(options.lotsPerBlockSide, 1, 8);
  const uint32_t variants = std::clamp<uint32_t>(options.buildingVariants, 1, 64);
  const uint32_t minFloors = std::max<uint32_t>(1, std::min(options.minFloors, options.maxFloors));
  const uint32_t maxFloors = std::max<uint32_t>(minFloors, options.maxFloors);
  detail::SplitMix64 rng(uint64_t(options.seed) * 0x9E3779B97F4A7C15ull + 1);

  Scene scene;
  scene.source = "generated:city";
  scene.materials.resize(kMaterialCount);
  scene.materials[kAsphalt] = material("asphalt", {0.05f, 0.05f, 0.055f, 1}, 0.9f);
  scene.materials[kSidewalk] = material("sidewalk", {1, 1, 1, 1}, 0.8f);
  scene.materials[kSidewalk].baseColorTexture = 0;
  scene.materials[kBrick] = material("brick", {0.45f, 0.17f, 0.11f, 1}, 0.85f);
  scene.materials[kConcrete] = material("concrete", {0.5f, 0.5f, 0.48f, 1}, 0.8f);
  scene.materials[kSandstone] = material("sandstone", {0.62f, 0.5f, 0.32f, 1}, 0.75f);
  scene.materials[kGlass] = material("glass", {0.45f, 0.6f, 0.7f, 0.35f}, 0.05f);
  scene.materials[kGlass].alphaMode = AlphaMode::Blend;
  scene.materials[kGlass].doubleSided = true;
  scene.materials[kPlaster] = material("plaster", {0.8f, 0.78f, 0.72f, 1}, 0.9f);
  scene.textures.push_back(pavingTexture(options.seed));

  const StreetGrid grid(options);
  const float blockSize = lots * kLot, pitch = grid.pitch, extent = grid.extent, origin = grid.origin;

  // Ground: asphalt under everything, with a street's width of margin.
  {
    Mesh ground;
    ground.name = "ground";
    ground.material = kAsphalt;
    float e = 0.5f * extent + kStreet;
    QuadBuilder{ground}.quad({-e, 0, -e}, {e, 0, -e}, {e, 0, e}, {-e, 0, e}, {0, 1, 0});
    scene.meshes.push_back(std::move(ground));
  }
  // Sidewalk slab, one mesh instanced per block.
  {
    Mesh slab;
    slab.name = "sidewalk";
    slab.material = kSidewalk;
    QuadBuilder{slab}.box({0, 0, 0}, {blockSize, kCurb, blockSize}, 4);
    scene.meshes.push_back(std::move(slab));
  }
  const uint32_t firstVariantMesh = uint32_t(scene.meshes.size());
  for (uint32_t i = 0; i < variants; ++i) {
    Variant v;
    v.width = rng.range(16.0f, 26.0f);
    v.depth = rng.range(16.0f, 26.0f);
    v.floorHeight = rng.range(3.0f, 3.6f);
    v.bay = rng.range(2.8f, 3.6f);
    v.floors = minFloors + rng.below(maxFloors - minFloors + 1);
    v.facade = kBrick + i % 3;
    Mesh shell, glass, interior;
    buildVariant(v, options.interiors, shell, glass, interior);
    std::string base = "building" + std::to_string(i);
    shell.name = base + "_shell", shell.material = v.facade;
    glass.name = base + "_glass", glass.material = kGlass;
    interior.name = base + "_interior", interior.material = kPlaster;
    scene.meshes.push_back(std::move(shell));
    scene.meshes.push_back(std::move(glass));
    if (options.interiors) scene.meshes.push_back(std::move(interior));
  }
  const uint32_t partsPerVariant = options.interiors ? 3 : 2;
  for (Mesh& m : scene.meshes) detail::computeBounds(m);

  scene.instances.push_back({0, glm::mat4(1.0f)});
  for (uint32_t bz = 0; bz < blocks; ++bz)
    for (uint32_t bx = 0; bx < blocks; ++bx) {
      glm::vec3 corner(origin + bx * pitch, 0.0f, origin + bz * pitch);
      scene.instances.push_back({1, glm::translate(glm::mat4(1.0f), corner)});
      for (uint32_t lz = 0; lz < lots; ++lz)
        for (uint32_t lx = 0; lx < lots; ++lx) {
          uint32_t variant = rng.below(variants);
          float angle = glm::radians(90.0f * float(rng.below(4)));
          glm::vec3 centre = corner + glm::vec3((lx + 0.5f) * kLot, kCurb, (lz + 0.5f) * kLot);
          glm::mat4 m = glm::rotate(glm::translate(glm::mat4(1.0f), centre), angle, glm::vec3(0, 1, 0));
          for (uint32_t part = 0; part < partsPerVariant; ++part)
            scene.instances.push_back({firstVariantMesh + variant * partsPerVariant + part, m});
        }
    }
  return scene;
}

} // namespace mirage::io
