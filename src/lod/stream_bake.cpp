// bakeLodFile: meshes made, baked and encoded by a few workers at once (each on its share of the
// threads), their chunks written in mesh order by the calling thread as soon as their turn comes.
#include "mirage/lod/stream_bake.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <map>
#include <mutex>
#include <optional>
#include <thread>

#include <tbb/task_arena.h>
#include <unistd.h>

#include "asset_parts.h"
#include "stream_resume.h"
#include "mirage/core/temp_files.h"
#include "mirage/asset/container.h"
#include "mirage/asset/scene_chunk.h"
#include "mirage/lod/dag_codec.h"
#include "mirage/lod/paged_asset.h"

namespace mirage::lod {

namespace {

// One mesh, baked and encoded: what the writer needs, nothing of the DAG.
struct EncodedMesh {
  asset::StoredChunk dagChunk;       // not paged: the CDAG chunk as stored
  std::vector<uint8_t> pagedPayload; // paged: the CPAG payload
  std::vector<uint8_t> sourceMap;    // its TMAP section
  nlohmann::json stats;              // its META entry
  Bounds bounds;
  uint64_t triangles = 0, clusters = 0, pages = 0;
  double seconds[4] = {}; // make, bake, encode, read back
};

double since(std::chrono::steady_clock::time_point& t) { // seconds since t; t becomes now
  auto now = std::chrono::steady_clock::now();
  double s = std::chrono::duration<double>(now - t).count();
  t = now;
  return s;
}

// Generate, bake, encode and check one mesh on the calling thread's arena.
Result<EncodedMesh> bakeOne(const MeshSource& source, uint32_t index, const BuildConfig& config,
                            const LodWriteOptions& write, const std::string& path) {
  auto t = std::chrono::steady_clock::now();
  EncodedMesh out;
  auto mesh = source.mesh(index);
  if (!mesh) return mesh.error();
  out.seconds[0] = since(t);
  std::string where = meshWhere(source.layout, index);
  auto baked = bakeLodMesh(*mesh, where, config);
  if (!baked) return baked.error();
  out.seconds[1] = since(t);
  out.bounds = mesh->bounds;
  out.triangles = mesh->triangleCount();
  *mesh = Mesh{}; // the input goes before the encoding's buffers arrive
  const ClusterDag& dag = baked->dag;
  out.clusters = dag.clusters.size();
  out.stats = meshStatsJson(source.layout.meshes[index].name, dag);
  asset::ByteWriter map;
  writeSourceMap(map, baked->sourceClusters);
  out.sourceMap = map.take();
  // What saveLodAsset writes for this mesh, read back before it goes to the file.
  Result<ClusterDag> read = Error{};
  if (write.paged) {
    PageConfig pages = write.pages;
    pages.positionBits = write.dag.positionBits;
    auto payload = encodePagedChunk(dag, pages, 9);
    if (!payload)
      return makeError(path, "mesh " + std::to_string(index) + ": paged cluster DAG: " + payload.error().message);
    out.pagedPayload = std::move(*payload);
    out.seconds[2] = since(t);
    read = decodePagedChunk(out.pagedPayload, where);
    if (auto blocks = asset::decodeBlockTable(out.pagedPayload, where)) out.pages = blocks->blocks.size();
  } else {
    std::vector<uint8_t> bytes = encodeDag(dag, write.dag);
    int level = bytes.size() <= (4u << 20) ? 19 : 9; // saveLodAsset's choice
    auto chunk = asset::storeChunk(asset::chunk::ClusterDag, bytes, level);
    if (!chunk) return makeError(path, chunk.error().message);
    out.dagChunk = std::move(*chunk);
    out.seconds[2] = since(t);
    read = decodeDag(bytes, where);
  }
  if (!read)
    return makeError(path, "the written file does not read back (" + read.error().message + "); nothing written");
  if (std::string d = dagReadBackDifference(dag, *read, write.paged); !d.empty())
    return makeError(path, "the written file does not read back (" + where + ": " + d + "); nothing written");
  out.seconds[3] = since(t);
  return out;
}

// An EncodedMesh as bytes between processes (bakeStreamMesh, RemoteMeshBakers): every field, the
// stats as CBOR (their numbers keep their types, so META's text is the one-process text).
std::vector<uint8_t> encodeMesh(const EncodedMesh& e) {
  asset::ByteWriter w;
  const asset::ChunkInfo& c = e.dagChunk.info;
  w.write(c.type.code), w.write(uint8_t(c.compressed)), w.write(uint8_t(c.blocked));
  w.write(c.offset), w.write(c.storedBytes), w.write(c.rawBytes), w.write(c.storedHash), w.write(c.rawHash);
  w.write(c.zstdLevel), w.write(c.indexBytes);
  w.writeArray(std::span<const uint8_t>(e.dagChunk.stored));
  w.writeArray(std::span<const uint8_t>(e.pagedPayload));
  w.writeArray(std::span<const uint8_t>(e.sourceMap));
  std::vector<uint8_t> stats = nlohmann::json::to_cbor(e.stats);
  w.writeArray(std::span<const uint8_t>(stats));
  w.write(e.bounds.min), w.write(e.bounds.max);
  w.write(e.triangles), w.write(e.clusters), w.write(e.pages);
  for (double s : e.seconds) w.write(s);
  return w.take();
}

Result<EncodedMesh> decodeMesh(std::span<const uint8_t> bytes, const std::string& where) {
  asset::ByteReader r(bytes, where);
  EncodedMesh e;
  asset::ChunkInfo& c = e.dagChunk.info;
  uint8_t compressed = 0, blocked = 0;
  std::vector<uint8_t> stats;
  r.read(c.type.code), r.read(compressed), r.read(blocked);
  r.read(c.offset), r.read(c.storedBytes), r.read(c.rawBytes), r.read(c.storedHash), r.read(c.rawHash);
  r.read(c.zstdLevel), r.read(c.indexBytes);
  r.readArray(e.dagChunk.stored), r.readArray(e.pagedPayload), r.readArray(e.sourceMap), r.readArray(stats);
  r.read(e.bounds.min), r.read(e.bounds.max);
  r.read(e.triangles), r.read(e.clusters), r.read(e.pages);
  for (double& s : e.seconds) r.read(s);
  if (r.ok() && r.remaining() != 0) r.fail("trailing bytes");
  if (!r.ok()) return r.error();
  c.compressed = compressed != 0, c.blocked = blocked != 0;
  e.stats = decodeStats(stats);
  if (e.stats.is_discarded()) return makeError(where, "mesh statistics do not decode");
  return e;
}

// The TMAP sections in mesh order. Removed when the bake ends, however it ends (a signal too),
// unless resumable: then kept for a later process (its owner removes it).
struct SpoolFile {
  SpoolFile(std::string p, bool resumable) : path(std::move(p)), keep(resumable) {
    if (!keep) guard = TempFileGuard(path);
  }
  SpoolFile(const SpoolFile&) = delete;
  SpoolFile& operator=(const SpoolFile&) = delete;
  ~SpoolFile() {
    if (file) std::fclose(file);
    if (!keep && !path.empty()) std::remove(path.c_str());
  }
  bool write(std::span<const uint8_t> bytes) {
    bytes_ += bytes.size();
    return std::fwrite(bytes.data(), 1, bytes.size(), file) == bytes.size();
  }
  // Durable up to here: the mark of the sections since the previous one.
  Result<asset::FileMark> mark() {
    if (std::fflush(file) != 0) return makeError(path, "cannot write");
    auto m = asset::markFile(::fileno(file), path, marked_, bytes_);
    if (m) marked_ = bytes_;
    return m;
  }
  // Continues after `end`, the last mark (whose bytes were checked), cutting off what follows.
  bool resume(uint64_t end) {
    if (::truncate(path.c_str(), off_t(end)) != 0) return false;
    file = std::fopen(path.c_str(), "a+b"); // read too: marks read back what was written
    bytes_ = marked_ = end;
    return file != nullptr;
  }

  std::string path;
  bool keep = false;
  TempFileGuard guard; // while not resumable: removed when a signal stops the process
  std::FILE* file = nullptr;

private:
  uint64_t bytes_ = 0, marked_ = 0;
};

// The writer: of a bake without a journal, of a new resumable one, or of one continued after the
// meshes it resumes.
Result<asset::AssetStreamWriter> openWriter(const std::string& path, uint32_t chunks, const StreamJournal* journal) {
  if (!journal) return asset::AssetStreamWriter::create(path, chunks);
  const std::vector<StreamMeshRecord>& resumed = journal->resume.meshes;
  if (resumed.empty()) return asset::AssetStreamWriter::createResumable(path, streamPartialPath(path), chunks);
  std::vector<asset::ChunkEntry> table;
  for (const StreamMeshRecord& m : resumed) table.push_back(m.chunk);
  return asset::AssetStreamWriter::resume(path, streamPartialPath(path), chunks, table, resumed.back().file.end);
}

// A resumable bake's mesh `i`, just written: the partial output and spool made durable, then its
// record handed to the journal.
Status commit(const StreamJournal& journal, uint32_t i, asset::AssetStreamWriter& writer, SpoolFile& spool,
              const EncodedMesh& e) {
  StreamMeshRecord record;
  auto spoolMark = spool.mark();
  if (!spoolMark) return spoolMark.error();
  auto fileMark = writer.checkpoint();
  if (!fileMark) return fileMark.error();
  record.chunk = writer.table().back();
  record.file = *fileMark, record.spool = *spoolMark;
  record.bounds = e.bounds;
  record.stats = nlohmann::json::to_cbor(e.stats);
  record.triangles = e.triangles, record.clusters = e.clusters, record.pages = e.pages;
  return journal.commit(i, encodeStreamRecord(record));
}

} // namespace

StreamShare streamShare(const BuildConfig& config, const StreamBakeOptions& options, uint32_t meshCount) {
  uint32_t threads = config.threads ? config.threads : uint32_t(tbb::this_task_arena::max_concurrency());
  StreamShare s;
  s.meshesInFlight = options.meshesInFlight ? options.meshesInFlight : std::max(1u, threads / 2);
  s.meshesInFlight = std::max(1u, std::min(s.meshesInFlight, meshCount));
  s.threadsPerMesh = std::max(1u, threads / s.meshesInFlight);
  return s;
}

Result<std::vector<uint8_t>> bakeStreamMesh(const MeshSource& source, uint32_t index, const BuildConfig& config,
                                            const LodWriteOptions& write, const std::string& path) {
  if (index >= source.layout.meshes.size()) return makeError(path, "no mesh " + std::to_string(index));
  auto e = bakeOne(source, index, config, write, path);
  if (!e) return e.error();
  return encodeMesh(*e);
}

Status bakeLodFile(const MeshSource& source, const std::string& path, const BuildConfig& config,
                   const LodWriteOptions& write, const StreamBakeOptions& options, StreamBakeReport* report,
                   const BuildProgress& progress, const RemoteMeshBakers* remote, std::vector<uint32_t>* localMeshes,
                   const StreamJournal* journal) {
  auto t0 = std::chrono::steady_clock::now();
  const uint32_t meshCount = uint32_t(source.layout.meshes.size());
  if (meshCount == 0) return makeError(path, "the scene has no meshes");
  if (streamChunkCount(meshCount) > asset::kMaxChunks)
    return makeError(path, "too many meshes for one file (" + std::to_string(meshCount) + ")");
  const StreamShare share = streamShare(config, options, meshCount);
  const uint32_t inFlight = share.meshesInFlight;
  uint32_t window = std::max(inFlight, options.reorderWindow ? options.reorderWindow : 2 * inFlight);
  BuildConfig meshConfig = config;
  meshConfig.threads = share.threadsPerMesh;
  StreamBakeReport r;
  r.meshes = meshCount, r.meshesInFlight = inFlight, r.reorderWindow = window, r.threadsPerMesh = meshConfig.threads;

  const std::vector<StreamMeshRecord> noMeshes;
  const std::vector<StreamMeshRecord>& resumed = journal ? journal->resume.meshes : noMeshes;
  if (resumed.size() > meshCount) return makeError(path, "more meshes resumed than the scene has");
  r.resumedMeshes = uint32_t(resumed.size());
  auto writer = openWriter(path, streamChunkCount(meshCount), journal);
  if (!writer) return writer.error();
  SpoolFile spool(journal ? streamSpoolPath(path) : path + ".tmap-" + std::to_string(::getpid()), journal != nullptr);
  bool spoolOk = true;
  if (!resumed.empty()) {
    if (!spool.resume(resumed.back().spool.end)) return makeError(path, "cannot continue " + spool.path);
  } else {
    spool.file = std::fopen(spool.path.c_str(), journal ? "w+b" : "wb");
    if (!spool.file) return makeError(path, "cannot create " + spool.path);
    spoolOk = spool.write(sourceMapHeader(meshCount).data());
  }

  Scene scene; // the layout with every mesh's bounds: the SCEN chunk (no geometry)
  scene.source = source.layout.source;
  scene.materials = source.layout.materials;
  scene.textures = source.layout.textures;
  scene.instances = source.layout.instances;
  scene.lights = source.layout.lights;
  nlohmann::json stats = nlohmann::json::array();
  auto addMesh = [&](uint32_t i, const Bounds& bounds, nlohmann::json meshStats, uint64_t triangles, uint64_t clusters,
                     uint64_t pages) {
    const Mesh& layoutMesh = source.layout.meshes[i];
    scene.meshes.push_back(Mesh{layoutMesh.name, {}, {}, {}, {}, {}, {}, layoutMesh.material, bounds});
    stats.push_back(std::move(meshStats));
    r.inputTriangles += triangles, r.clusters += clusters, r.pages += pages;
  };
  for (uint32_t i = 0; i < r.resumedMeshes; ++i) {
    const StreamMeshRecord& e = resumed[i];
    nlohmann::json meshStats = decodeStats(e.stats);
    if (meshStats.is_discarded()) return makeError(path, "mesh " + std::to_string(i) + ": statistics do not decode");
    addMesh(i, e.bounds, std::move(meshStats), e.triangles, e.clusters, e.pages);
  }
  if (progress && r.resumedMeshes) progress(r.resumedMeshes, meshCount, r.resumedMeshes, meshCount);
  // Workers take meshes in order while they are fewer than `window` ahead of the writer; each
  // finished mesh waits in `done` until the writer (this thread) reaches it.
  std::mutex m;
  std::condition_variable cv;
  uint32_t next = r.resumedMeshes, written = r.resumedMeshes, busy = 0; // resumed meshes: not baked again
  std::map<uint32_t, EncodedMesh> done;
  std::optional<Error> error;
  // Under m: the next mesh may start (local worker or remote), within the window of the writer.
  auto withinWindow = [&] { return next < written + window; };
  auto work = [&] {
    tbb::task_arena arena(int(meshConfig.threads));
    while (true) {
      uint32_t i;
      {
        std::unique_lock lock(m);
        cv.wait(lock, [&] { return error || next >= meshCount || withinWindow(); });
        if (error || next >= meshCount) return;
        i = next++;
        r.peakMeshesInFlight = std::max(r.peakMeshesInFlight, ++busy);
        if (localMeshes) localMeshes->push_back(i);
      }
      Result<EncodedMesh> e = Error{};
      arena.execute([&] { e = bakeOne(source, i, meshConfig, write, path); });
      std::lock_guard lock(m);
      --busy;
      if (!e) {
        if (!error) error = e.error();
      } else {
        done.emplace(i, std::move(e).value());
        r.peakMeshesWaiting = std::max(r.peakMeshesWaiting, uint32_t(done.size()));
      }
      cv.notify_all();
    }
  };
  std::vector<std::thread> workers;
  for (uint32_t w = 0; w < inFlight; ++w) workers.emplace_back(work);

  // Remote workers take meshes under the same window and deliver them into `done` (pumped by this
  // thread between writes, at least every millisecond while it waits).
  RemoteMeshBakers::Take take = [&]() -> std::optional<uint32_t> {
    std::lock_guard lock(m);
    if (error || next >= meshCount || !withinWindow()) return std::nullopt;
    return next++;
  };
  RemoteMeshBakers::Deliver deliver = [&](uint32_t i, Result<std::vector<uint8_t>> bytes) {
    Result<EncodedMesh> e =
        bytes ? decodeMesh(*bytes, meshWhere(source.layout, i)) : Result<EncodedMesh>(bytes.error());
    std::lock_guard lock(m);
    if (!e) {
      if (!error) error = e.error();
    } else if (i < meshCount && i >= written && !done.count(i)) {
      done.emplace(i, std::move(e).value());
      r.peakMeshesWaiting = std::max(r.peakMeshesWaiting, uint32_t(done.size()));
    } else if (!error) {
      error = makeError(path, "mesh " + std::to_string(i) + " delivered twice");
    }
    cv.notify_all();
  };
  Status status = Ok{};
  while (written < meshCount) {
    EncodedMesh e;
    {
      std::unique_lock lock(m);
      auto ready = [&] { return error || done.count(written); };
      while (remote && !ready()) {
        lock.unlock();
        remote->pump(take, deliver);
        lock.lock();
        cv.wait_for(lock, std::chrono::milliseconds(1), ready);
      }
      cv.wait(lock, ready);
      if (error) break;
      auto it = done.find(written);
      e = std::move(it->second);
      done.erase(it);
    }
    status = write.paged ? writer->addBlockedChunk(asset::chunk::ClusterPages, e.pagedPayload, 9)
                         : writer->addStoredChunk(e.dagChunk);
    spoolOk = spoolOk && spool.write(e.sourceMap);
    if (journal && status && spoolOk) status = commit(*journal, written, *writer, spool, e);
    addMesh(written, e.bounds, std::move(e.stats), e.triangles, e.clusters, e.pages);
    r.makeSeconds += e.seconds[0], r.meshBakeSeconds += e.seconds[1];
    r.encodeSeconds += e.seconds[2], r.readBackSeconds += e.seconds[3];
    std::lock_guard lock(m);
    if (!status && !error) error = status.error();
    if (!spoolOk && !error) error = makeError(path, "cannot write " + spool.path);
    if (error) break;
    ++written;
    cv.notify_all();
    if (progress) progress(written, meshCount, written, meshCount);
  }
  {
    std::lock_guard lock(m);
    if (written < meshCount && !error) error = makeError(path, "bake stopped");
    cv.notify_all();
  }
  for (std::thread& t : workers) t.join();
  if (error) return *error;
  r.bakeSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  auto t1 = std::chrono::steady_clock::now();
  if (std::fclose(std::exchange(spool.file, nullptr)) != 0) return makeError(path, "cannot write " + spool.path);
  if (Status s = writer->addChunkFromFile(asset::chunk::SourceMap, spool.path); !s) return s;
  if (!journal) { // resumable: kept until the output is in place (a kill before that resumes from it)
    std::remove(spool.path.c_str());
    spool.path.clear();
  }
  if (Status s = asset::validateScene(scene, path); !s) return s;
  if (Status s = writer->addChunk(asset::chunk::Scene, asset::encodeScene(scene)); !s) return s;
  std::string meta = lodMetaJson(source.layout.source, config, std::move(stats));
  if (Status s =
          writer->addChunk(asset::chunk::Meta, std::span(reinterpret_cast<const uint8_t*>(meta.data()), meta.size()));
      !s)
    return s;
  r.fileBytes = writer->bytesWritten();
  // The container and every paged mesh's index read back (each mesh's pages were read back above).
  Status finished = writer->finish([&](const std::string& tempPath) -> Status {
    auto reader = asset::AssetReader::open(tempPath);
    if (!reader) return makeError(path, "the written file does not read back (" + reader.error().message + ")");
    if (write.paged) {
      auto meshes = openPagedMeshes(*reader);
      if (!meshes || meshes->size() != meshCount)
        return makeError(path, "the written file does not read back (" +
                                   (meshes ? std::string("mesh count differs") : meshes.error().message) + ")");
    }
    return Ok{};
  });
  if (!finished) return finished;
  if (journal) std::remove(spool.path.c_str());
  r.finishSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  if (report) *report = r;
  return Ok{};
}

} // namespace mirage::lod
