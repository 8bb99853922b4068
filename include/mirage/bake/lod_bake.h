#pragma once
// `mirage build` on every rank of a World: one work unit per mesh (lod::bakeLodMesh), scheduled by
// runUnits, gathered on rank 0 into the same LodAsset (and so the same .mrg bytes) as the
// single-process lod::bakeLodAsset. docs/bake.md.
#include <string>

#include "mirage/bake/scheduler.h"
#include "mirage/core/scene.h"
#include "mirage/lod/lod_asset.h"

namespace mirage::bake {

struct BakeRun {
  std::string journal; // journal path ("" = none); journalPath(output) by convention
  bool resume = false; // continue from the journal
};

// The journal beside an output file.
inline std::string journalPath(const std::string& output) { return output + ".journal"; }

// What a mesh's DAG depends on: its geometry (name, positions, normals, uvs, indices) and the
// build settings (threads excepted: the DAG does not depend on them).
uint64_t lodFingerprint(const Scene& scene, const lod::BuildConfig& config);

// Collective: every rank passes the same config; only rank 0 needs the scene (it sends each rank
// the meshes it bakes: the others pass an empty Scene and import nothing). Rank 0 gets the asset;
// other ranks an empty one. config.threads is each rank's own (World::threadShare when the caller
// leaves it 0 in a world of several).
Result<lod::LodAsset> bakeLodAsset(const World& world, const Scene& scene, lod::BuildConfig config, const BakeRun& run,
                                   ScheduleReport* report = nullptr, const UnitProgress& progress = {});

} // namespace mirage::bake
