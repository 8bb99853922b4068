#pragma once
// Inputs of the runtime: scene arguments (files and generated scenes), what a .mrg holds, surfel
// clouds, and the PVS helpers the forward path and `bench pvs` share.
#include <array>
#include <optional>
#include <string>

#include <glm/glm.hpp>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/io/generate.h"
#include "mirage/io/import.h"
#include "mirage/render/camera.h"
#include "mirage/surfels/surfel.h"
#include "mirage/visibility/pvs_storage.h"

namespace mirage::runtime {

// A scene file, or "gen:KIND[:SIZE[:SEED]]" for a procedural scene made in memory (no file needed,
// which is how benchmarks run on machines without the data set).
Result<mirage::Scene> loadSceneArgument(const std::string& argument, const io::ImportOptions& options = {});
// "gen:many[:COUNT[xTRIANGLES][:SEED]]" (io::ManyOptions): the options, or an error naming the
// argument; nullopt for any other argument. A bake generates such a scene mesh by mesh
// (lod/stream_bake.h) instead of loading it whole.
std::optional<Result<io::ManyOptions>> manySceneArgument(const std::string& argument);

// "gen:KIND[:SIZE[:SEED]]" taken apart (io::generateScene's arguments; SIZE 0 when absent, SEED 1).
struct GenArgument {
  std::string kind;
  uint64_t size = 0;
  uint32_t seed = 1;
};
Result<GenArgument> parseGenArgument(const std::string& argument);

bool isMrgPath(const std::string& input);
// Which kinds of chunk a .mrg holds (all false when it cannot be opened: the loader reports why).
struct MrgContents {
  bool clusterDags = false, surfels = false, pvs = false, scene = false;
};
MrgContents mrgContents(const std::string& input);

// The cloud of a .mrg (its 'SURF' chunk; the material of the scene's first mesh when the file also
// holds a scene) or of a surfel PLY. Surfel-only files get a dielectric, moderately rough material.
Result<surfels::SurfelCloud> loadSurfelCloud(const std::string& path, Material& material);

// A PVS baked for `scene` (same triangle count); else an error naming `pvsPath`.
Status checkPvsScene(const mirage::Scene& scene, const vis::PvsData& pvs, const std::string& pvsPath);
// The view cell of `pvs` (loaded from `pvsPath`) holding `eye`; an error naming the file when the
// eye is in none (the forward path has no culling to fall back on).
Result<int> pvsCellOf(const vis::PvsData& pvs, const std::string& pvsPath, glm::vec3 eye);
// The scene restricted to the PVS of the view cell holding `eye` (`pvs` loaded from `pvsPath`, a
// .mrg from `mirage pvs`, which errors name). Errors: a PVS of another scene, an eye in none of its
// cells. `cell` receives the cell index.
Result<mirage::Scene> restrictSceneToPvs(const mirage::Scene& scene, const vis::PvsData& pvs,
                                         const std::string& pvsPath, glm::vec3 eye, int& cell);

// The four views the PVS benches time from a view cell: at its centre, level, 90 degrees apart,
// 70 degree field of view (clip planes left for the caller to derive).
std::array<render::Camera, 4> cellViewCameras(const vis::ViewCell& cell);

} // namespace mirage::runtime
