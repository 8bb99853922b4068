#pragma once
// The streaming `mirage build` (gen:many: meshes made one at a time, memory bounded) on every rank
// of a World. Rank 0 writes the file exactly as lod::bakeLodFile does in one process, baking meshes
// on its own workers and handing others to the other ranks; every rank makes the meshes it is
// given from the same MeshSource (generated, so nothing of the scene travels but mesh numbers), bakes
// and encodes them on its own workers, and sends each encoded chunk back. The bytes equal the
// one-process bake's. docs/bake.md.
#include <string>

#include "mirage/bake/scheduler.h"
#include "mirage/bake/world.h"
#include "mirage/lod/stream_bake.h"

namespace mirage::bake {

// Collective: every rank passes the same source, config and options (config.threads and
// options.meshesInFlight are each rank's own; 0 = World::threadShare and half of it). Rank 0's
// reorder window also bounds the meshes out on other ranks, so its memory stays that of the window.
// Rank 0 gets the reports (`ranks`: the meshes each rank baked); every rank gets Ok or the same
// error, and nothing is left at `path` on failure.
Status bakeLodFile(const World& world, const lod::MeshSource& source, const std::string& path, lod::BuildConfig config,
                   const lod::LodWriteOptions& write, const lod::StreamBakeOptions& options,
                   lod::StreamBakeReport* report = nullptr, ScheduleReport* ranks = nullptr,
                   const lod::BuildProgress& progress = {});

} // namespace mirage::bake
