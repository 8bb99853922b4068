#pragma once
// Procedural test scenes, deterministic for a seed (same options -> identical bytes on any run and
// any thread count): a city (instancing, heavy occlusion, alpha-blended glass), a terrain heightfield
// (one big open mesh) and a displaced icosphere "blob" (one big closed manifold mesh).
#include <cstdint>
#include <string_view>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"

namespace mirage::io {

struct CityOptions {
  uint32_t blocks = 4;           // city blocks per side of the square street grid (1..256)
  uint32_t seed = 1;             // drives building variants, placement and rotation
  uint32_t lotsPerBlockSide = 2; // building lots per side of a block (lots² buildings per block)
  uint32_t buildingVariants = 4; // distinct building meshes, instanced across all lots
  uint32_t minFloors = 3;        // storeys of the lowest variant
  uint32_t maxFloors = 16;       // storeys of the highest variant
  bool interiors = true;         // floor slabs and interior walls with door openings
};

struct TerrainOptions {
  uint32_t resolution = 1024; // vertices per side: N×N grid, 2(N-1)² triangles (2..8192)
  float size = 1000.0f;       // side length in metres, centred on the origin in XZ
  float heightScale = 150.0f; // peak-to-valley scale of the heights in metres
  float featureSize = 300.0f; // wavelength of the lowest noise octave in metres
  uint32_t octaves = 8;       // fBm octaves (more = finer detail)
  uint32_t seed = 1;          // noise seed
  bool vertexColors = true;   // grass/rock/snow colours by slope and height in Mesh::colors
};

struct BlobOptions {
  uint32_t subdivisions = 8; // icosphere subdivision levels: 20·4^s triangles, 10·4^s+2 vertices (0..11)
  uint32_t segments = 0;     // segments per icosahedron edge n (20·n² triangles, 1..8192); 0: 2^subdivisions
  float radius = 1.0f;       // radius of the undisplaced sphere
  float amplitude = 0.25f;   // displacement along the normal, relative to the radius
  float frequency = 2.0f;    // noise frequency on the unit sphere (lowest octave)
  uint32_t octaves = 5;      // fBm octaves of the displacement
  uint32_t seed = 1;         // noise seed
};

// A stack of alpha-blended, double-sided 2 x 2 quads along z (transparency benchmark and test):
// quad i at z = (i - (layers - 1) / 2) * spacing, tilted about y by +/- tiltDegrees alternately,
// so neighbours intersect; one mesh and material (hue by layer) each.
struct LayersOptions {
  uint32_t layers = 8; // 1..1024
  float spacing = 0.05f;
  float tiltDegrees = 3.0f;
  float alpha = 0.3f;
};

// Many distinct meshes (`gen:many:COUNTxTRIANGLES[:SEED]`): `count` blob variants of about
// `triangles` triangles each (seed, amplitude, frequency and octaves vary per mesh), one instance
// each, scattered with jitter, scale and rotation over a square grid on the ground (y = 0), so a
// camera flying over them sees near and far meshes. Made mesh by mesh: the layout alone (no
// geometry) and any mesh on its own, so a bake can generate each mesh when it bakes it and a
// scene of billions of triangles never exists in memory at once (lod/stream_bake.h).
struct ManyOptions {
  uint32_t count = 16;         // distinct meshes (1..65536)
  uint64_t triangles = 100000; // triangles per mesh, about: 20·n² with n = round(sqrt(triangles / 20)) (20..1.3e9)
  uint32_t seed = 1;           // drives every mesh's variant and the layout
  float spacing = 4.0f;        // grid step in metres (blob radius ≈ 1 before scaling)
};
// The scene without geometry: materials, instances, one mesh per variant with its name and
// material (no vertices, bounds empty). Meshes are generateManyMesh(options, i).
Scene generateManyLayout(const ManyOptions& options);
// Mesh `index` of the layout, with its geometry and bounds (thread-safe, any order).
Mesh generateManyMesh(const ManyOptions& options, uint32_t index);
// The whole scene: the layout with every mesh generated (small scenes and tests).
Scene generateMany(const ManyOptions& options);
// "COUNT" or "COUNTxTRIANGLES" (the SIZE of gen:many); `seed` as given. Errors: syntax, ranges.
Result<ManyOptions> parseManySize(std::string_view size, uint32_t seed);

Scene generateCity(const CityOptions& options);
// View cells of a walk through every street of generateCity(options): the 2 (blocks + 1) street
// centre lines (between and around the blocks, along x and along z), `perStreet` boxes evenly spaced
// on each, 4 m across and along the street at eye height (y 0.7..2.7 m). Empty for perStreet 0.
std::vector<Bounds> cityStreetCells(const CityOptions& options, uint32_t perStreet);
Scene generateLayers(const LayersOptions& options);
Scene generateTerrain(const TerrainOptions& options);
Scene generateBlob(const BlobOptions& options);

// A synthetic scan: `count` points uniformly distributed over the surface of every instance of
// `source` (world space, area-weighted), with interpolated unit normals and colours (the mesh's
// vertex colours, else the normal mapped to RGB). One mesh without indices (a point cloud),
// identity instance. Deterministic for a seed (any thread count). Errors: no triangles, count 0.
// surfaceArea (optional) receives the sampled surface's area (what a sampler's A should approach).
Result<Scene> samplePointCloud(const Scene& source, uint64_t count, uint32_t seed, double* surfaceArea = nullptr);

// kind is "city", "terrain", "blob", "layers" or "many"; sizeParameter is blocks / resolution /
// subdivisions / layers / mesh count (0 = the default; gen:many's triangles: parseManySize). Unknown kinds and
// out-of-range sizes are errors.
Result<Scene> generateScene(std::string_view kind, uint32_t seed, uint64_t sizeParameter);
// The options generateScene("city", seed, sizeParameter) generates with (blocks 1..256; 0 = default).
Result<CityOptions> cityOptions(uint32_t seed, uint64_t sizeParameter);

} // namespace mirage::io
