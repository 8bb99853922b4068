#pragma once
// The streaming `mirage build` (gen:many: meshes made one at a time, memory bounded) on every rank
// of a World. Rank 0 writes the file exactly as lod::bakeLodFile does in one process, baking meshes
// on its own workers and handing others to the other ranks; every rank makes the meshes it is
// given from the same MeshSource (generated, so nothing of the scene travels but mesh numbers), bakes
// and encodes them on its own workers, and sends each encoded chunk back. The bytes equal the
// one-process bake's. docs/bake.md.
//
// Resumable (run.resume, `mirage build gen:many:... --resume`): rank 0 keeps the partial output and
// the TMAP spool under fixed names (lod::streamPartialPath, lod::streamSpoolPath) and records each
// mesh written, once durable, in the journal (run.journal, the format of journal.h: one entry per
// mesh, its lod::StreamMeshRecord). A bake killed at any point (a signal: they leave these files; a
// dead rank; the walltime) continues with --resume from the recorded meshes, which no rank bakes
// again, to the bytes of an uninterrupted bake.
#include <string>

#include "mirage/bake/lod_bake.h"
#include "mirage/bake/scheduler.h"
#include "mirage/bake/world.h"
#include "mirage/lod/stream_bake.h"

namespace mirage::bake {

// What a streaming bake's journal depends on: the source's key and mesh names, the build settings
// (threads excepted) and the write options (threads excepted), the record's version.
uint64_t streamFingerprint(const lod::MeshSource& source, const lod::BuildConfig& config,
                           const lod::LodWriteOptions& write);

// Collective: every rank passes the same source, config and options (config.threads and
// options.meshesInFlight are each rank's own; 0 = World::threadShare and half of it). Rank 0's
// reorder window also bounds the meshes out on other ranks, so its memory stays that of the window.
// Rank 0 gets the reports (`ranks`: the meshes each rank baked; resumedUnits); every rank gets Ok or
// the same error, and nothing is left at `path` on failure. `run` (rank 0's matters): with resume,
// the journal and the partial output are checked and continued (refused with one line, and left as
// they are, when they belong to another bake or are damaged), and removed once the output is written
// or the bake failed with an error (bad input fails the same way again); without resume, nothing is
// journaled, and an earlier bake's journal and partial output at these names are removed once the
// output is written.
Status bakeLodFile(const World& world, const lod::MeshSource& source, const std::string& path, lod::BuildConfig config,
                   const lod::LodWriteOptions& write, const lod::StreamBakeOptions& options,
                   lod::StreamBakeReport* report = nullptr, ScheduleReport* ranks = nullptr,
                   const lod::BuildProgress& progress = {}, const BakeRun& run = {});

} // namespace mirage::bake
