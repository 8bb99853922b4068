#pragma once
// A cluster-LOD bake whose memory does not grow with the scene (docs/lod.md, "Streaming bake"):
// meshes are made on demand (generated or read one at a time), baked a bounded number at once,
// and each mesh's chunk is written to the output as soon as the meshes before it are, so the
// process holds about meshesInFlight meshes being baked plus reorderWindow encoded chunks, never
// the scene. The file holds the chunks saveLodAsset writes for the same scene (the same contents:
// every CPAG/CDAG chunk's stored bytes, the TMAP, SCEN and META payloads), with the scene chunk
// after the meshes (their bounds are known once they are made); bytes independent of the thread
// count and of the order meshes finish in.
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "mirage/asset/file_marks.h"
#include "mirage/asset/format.h"
#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/lod/cluster_dag.h"
#include "mirage/lod/lod_asset.h"

namespace mirage::lod {

// A scene whose meshes are made one at a time.
struct MeshSource {
  // Materials, textures, instances, lights; one mesh per DAG with its name and material (geometry
  // and bounds come from `mesh`).
  Scene layout;
  // Mesh i with its geometry and bounds; called from several threads at once, for distinct i.
  std::function<Result<Mesh>(uint32_t)> mesh;
  // What `mesh` makes, as text (e.g. "gen:many:64x100000:1"): with the mesh names and the settings,
  // what identifies a resumable bake (bake::streamFingerprint). "" = unknown: it cannot be resumed.
  std::string key;
};

struct StreamBakeOptions {
  // Meshes made, baked and encoded at once, each on threads / meshesInFlight of the build's threads
  // (at least 1); 0: half the threads, at least 1 (a mesh's encoding and read-back run on one
  // thread, so two threads per mesh keep the cores busy). Memory: about this many meshes' bakes
  // (about 150-250 B per input triangle each, docs/lod.md "Streaming bake").
  uint32_t meshesInFlight = 0;
  // A mesh starts only when it is fewer than this many ahead of the next mesh to write, so at most
  // this many finished meshes wait, encoded, for their turn; 0: 2 × meshesInFlight (≥ meshesInFlight).
  uint32_t reorderWindow = 0;
};

struct StreamBakeReport {
  uint32_t meshes = 0;
  uint32_t resumedMeshes = 0;  // written by an earlier process (StreamJournal): not baked here
  uint64_t inputTriangles = 0; // these three over every mesh of the file, resumed ones included
  uint64_t clusters = 0;
  uint64_t pages = 0; // paged: pages
  uint64_t fileBytes = 0;
  uint32_t meshesInFlight = 0, reorderWindow = 0, threadsPerMesh = 0; // as run
  // The counters the bound rests on: meshes made and not yet encoded at any time (each holds its
  // mesh and DAG), and encoded meshes waiting for their turn.
  uint32_t peakMeshesInFlight = 0;
  uint32_t peakMeshesWaiting = 0;
  double bakeSeconds = 0; // from the first mesh to the last mesh's chunk written
  // Wall seconds of each step summed over the meshes (each ran on threadsPerMesh threads): making
  // the mesh, its DAG (bakeLodMesh), encoding its chunk, reading the chunk back.
  double makeSeconds = 0, meshBakeSeconds = 0, encodeSeconds = 0, readBackSeconds = 0;
  double finishSeconds = 0; // the source map, scene and META chunks, the read-back check, rename
};

// How one process of a streaming bake spreads its threads (config.threads, 0 = all cores) over the
// meshes it bakes at once: options.meshesInFlight, or half the threads (at least 1), at most
// meshCount; each mesh gets threads / meshes in flight (at least 1).
struct StreamShare {
  uint32_t meshesInFlight = 1;
  uint32_t threadsPerMesh = 1;
};
StreamShare streamShare(const BuildConfig& config, const StreamBakeOptions& options, uint32_t meshCount);

// Meshes baked by other processes of the same bake (bake::bakeLodFile spreads a streaming bake
// over MPI ranks through this; the lod module knows nothing of MPI). The writing thread calls pump
// between writes, never holding a lock: it hands meshes to idle remote workers through `take`
// (nullopt: none may start now, the reorder window is full or every mesh is taken) and returns what
// they finished through `deliver`, as bakeStreamMesh's bytes or the error. pump must not block long.
struct RemoteMeshBakers {
  using Take = std::function<std::optional<uint32_t>()>;
  using Deliver = std::function<void(uint32_t mesh, Result<std::vector<uint8_t>> bytes)>;
  std::function<void(const Take& take, const Deliver& deliver)> pump;
};

// Mesh `index` of a streaming bake made, baked, encoded and read back as bakeLodFile's own workers
// do it (config.threads: this mesh's threads), as bytes for the process that writes the file. The
// bytes do not depend on the process or its thread count.
Result<std::vector<uint8_t>> bakeStreamMesh(const MeshSource& source, uint32_t index, const BuildConfig& config,
                                            const LodWriteOptions& write, const std::string& path);

// A resumable bake (docs/bake.md, "Journal and --resume"). Its partial output and TMAP spool have
// fixed names beside the output, so a later process finds them; after each mesh is written, both are
// made durable (fdatasync) and only then is the mesh's record handed to `commit`, which keeps it
// (bake::bakeLodFile: in the journal). A bake killed at any point (a signal, a dead rank, a host
// crash) continues from the recorded meshes: their bytes checked, whatever follows them cut off.
inline std::string streamPartialPath(const std::string& path) { return path + ".partial"; }
inline std::string streamSpoolPath(const std::string& path) { return path + ".tmap"; }
// Removes both (the bake is written, or failed for good).
void removeStreamFiles(const std::string& path);
// Changes with the record's layout (part of bake::streamFingerprint: an older journal is another bake's).
inline constexpr uint32_t kStreamRecordVersion = 1;

// One mesh a resumable bake wrote, as its record tells.
struct StreamMeshRecord {
  asset::ChunkEntry chunk{};   // its chunk's table entry
  asset::FileMark file, spool; // the partial output and the spool up to this mesh's end
  Bounds bounds;               // for the scene chunk
  std::vector<uint8_t> stats;  // its META entry as CBOR (numbers keep their types)
  uint64_t triangles = 0, clusters = 0, pages = 0;
};

// The meshes 0..K-1 an earlier process of the same bake wrote, checked.
struct StreamResume {
  std::vector<StreamMeshRecord> meshes;
};

// Decodes `records` (mesh i's at i, as `commit` got them) and checks each mesh's bytes in the
// partial output and spool of the bake to `path`; no records: a new bake. Changes nothing. Errors,
// one line: a record that does not decode, a partial output or spool missing, or one whose bytes
// differ from a mesh's record (naming the mesh).
Result<StreamResume> checkStreamResume(const std::string& path, uint32_t meshCount,
                                       std::span<const std::vector<uint8_t>> records);

struct StreamJournal {
  StreamResume resume; // the meshes written before (checkStreamResume); empty: a new bake
  // Mesh i's record, once its chunk and TMAP section are durable, in mesh order; an error stops the
  // bake with that error.
  std::function<Status(uint32_t mesh, std::span<const uint8_t> record)> commit;
};

// Bakes every mesh of `source` into `path` (config.threads: all the bake's threads, 0 = all cores;
// write.threads is not used: each mesh's chunk is encoded by the threads that baked it). The
// source-triangle map is spooled to "<path>.tmap-<pid>" beside the output and compressed into it
// at the end. Before the rename the file is opened again and every paged mesh's index read (pages
// were checked by the encoder; a full read would load the scene). Errors name the mesh or the
// output; nothing is left at `path` (or beside it) on failure. `remote`: other processes bake some
// of the meshes (their chunks are written in turn like the local ones; the bytes stay the same);
// `localMeshes` gets the meshes this process baked itself. `journal`: a resumable bake, which starts
// after journal->resume's meshes (no process bakes them again) and whose partial output and spool
// are left as they are on an error (their owner removes them, or keeps them to resume).
Status bakeLodFile(const MeshSource& source, const std::string& path, const BuildConfig& config,
                   const LodWriteOptions& write, const StreamBakeOptions& options = {},
                   StreamBakeReport* report = nullptr, const BuildProgress& progress = {},
                   const RemoteMeshBakers* remote = nullptr, std::vector<uint32_t>* localMeshes = nullptr,
                   const StreamJournal* journal = nullptr);

} // namespace mirage::lod
