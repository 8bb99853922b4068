#pragma once
// Procedural test scenes, deterministic for a seed (same options -> identical bytes on any run and
// any thread count): a city (instancing, heavy occlusion, alpha-blended glass), a terrain heightfield
// (one big open mesh) and a displaced icosphere "blob" (one big closed manifold mesh).
#include <cstdint>
#include <string_view>

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

Scene generateCity(const CityOptions& options);
Scene generateLayers(const LayersOptions& options);
Scene generateTerrain(const TerrainOptions& options);
Scene generateBlob(const BlobOptions& options);

// A synthetic scan: `count` points uniformly distributed over the surface of every instance of
// `source` (world space, area-weighted), with interpolated unit normals and colours (the mesh's
// vertex colours, else the normal mapped to RGB). One mesh without indices (a point cloud),
// identity instance. Deterministic for a seed (any thread count). Errors: no triangles, count 0.
// surfaceArea (optional) receives the sampled surface's area (what a sampler's A should approach).
Result<Scene> samplePointCloud(const Scene& source, uint64_t count, uint32_t seed, double* surfaceArea = nullptr);

// kind is "city", "terrain", "blob" or "layers"; sizeParameter is blocks / resolution /
// subdivisions / layers (0 = the default). Unknown kinds and out-of-range sizes are errors.
Result<Scene> generateScene(std::string_view kind, uint32_t seed, uint64_t sizeParameter);

} // namespace mirage::io
