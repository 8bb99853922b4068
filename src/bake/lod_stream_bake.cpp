// The streaming LOD bake over ranks: rank 0 runs lod::bakeLodFile with RemoteMeshBakers that hand
// mesh numbers to the other ranks' worker pools and take their encoded meshes back. Every MPI call
// is on each process's main thread (World is initialized MPI_THREAD_FUNNELED).
#include "mirage/bake/lod_stream_bake.h"

#include <chrono>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <mutex>
#include <optional>
#include <thread>

#include <tbb/task_arena.h>
#include <unistd.h>

#include "hasher.h"
#include "mirage/bake/journal.h"
#include "mirage/lod/dag_codec.h"
#include "mirage/lod/paged_asset.h"
#include "mirage/lod/paging.h"

namespace mirage::bake {

namespace {

// A worker rank says Ready (with how many meshes it bakes at once), then answers each Assign with a
// Result or a Failure; rank 0 ends with Stop, and the worker answers Stopped once nothing of it is
// left in flight (so no message stays unreceived when the ranks agree on the outcome).
enum Tag : int { kReady = 11, kAssign = 12, kResult = 13, kFailure = 14, kStop = 15, kStopped = 16 };

using Clock = std::chrono::steady_clock;

std::vector<uint8_t> numberBytes(uint32_t n) {
  std::vector<uint8_t> b(4);
  std::memcpy(b.data(), &n, 4);
  return b;
}
uint32_t numberOf(std::span<const uint8_t> b) {
  uint32_t n = ~0u;
  if (b.size() >= 4) std::memcpy(&n, b.data(), 4);
  return n;
}

// A rank other than 0: a pool of bakers (lod::streamShare, as rank 0's own) fed by the main thread,
// which alone talks to rank 0.
Status work(const World& world, const lod::MeshSource& source, const std::string& path, const lod::BuildConfig& config,
            const lod::LodWriteOptions& write, const lod::StreamBakeOptions& options) {
  const lod::StreamShare share = lod::streamShare(config, options, uint32_t(source.layout.meshes.size()));
  lod::BuildConfig meshConfig = config;
  meshConfig.threads = share.threadsPerMesh;
  std::mutex m;
  std::condition_variable cv;
  std::deque<uint32_t> queue;
  std::deque<std::pair<uint32_t, Result<std::vector<uint8_t>>>> finished;
  bool stopping = false;
  uint32_t busy = 0;
  auto baker = [&] {
    tbb::task_arena arena(int(meshConfig.threads));
    for (;;) {
      uint32_t mesh;
      {
        std::unique_lock lock(m);
        cv.wait(lock, [&] { return stopping || !queue.empty(); });
        if (stopping) return;
        mesh = queue.front();
        queue.pop_front();
        ++busy;
      }
      Result<std::vector<uint8_t>> bytes = Error{};
      arena.execute([&] { bytes = lod::bakeStreamMesh(source, mesh, meshConfig, write, path); });
      std::lock_guard lock(m);
      --busy;
      finished.emplace_back(mesh, std::move(bytes));
      cv.notify_all();
    }
  };
  std::vector<std::thread> bakers;
  for (uint32_t i = 0; i < share.meshesInFlight; ++i) bakers.emplace_back(baker);
  world.send(0, kReady, numberBytes(share.meshesInFlight));
  bool stopped = false;
  for (;;) {
    bool active = false;
    while (auto e = world.poll()) {
      active = true;
      std::vector<uint8_t> message = world.receive(*e);
      std::lock_guard lock(m);
      if (e->tag == kAssign && !stopping) queue.push_back(numberOf(message));
      if (e->tag == kStop) stopping = true, stopped = true, queue.clear();
      cv.notify_all();
    }
    std::unique_lock lock(m);
    while (!finished.empty()) {
      active = true;
      auto [mesh, bytes] = std::move(finished.front());
      finished.pop_front();
      lock.unlock();
      std::vector<uint8_t> reply = numberBytes(mesh);
      if (bytes) {
        reply.insert(reply.end(), bytes->begin(), bytes->end());
        bytes->clear();
        bytes->shrink_to_fit();
        world.send(0, kResult, reply);
      } else {
        const std::string& text = bytes.error().message;
        reply.insert(reply.end(), text.begin(), text.end());
        world.send(0, kFailure, reply);
      }
      lock.lock();
    }
    if (stopped && busy == 0 && finished.empty()) break;
    if (!active) cv.wait_for(lock, std::chrono::milliseconds(1));
  }
  for (std::thread& t : bakers) t.join();
  world.send(0, kStopped, {});
  return Ok{}; // a mesh's error went to rank 0, which reports it for every rank
}

// Rank 0's side of the other ranks: their free places and which meshes each baked.
class RemoteRanks {
public:
  explicit RemoteRanks(const World& world) : world_(world), free_(size_t(world.size()), 0), units_(world.size()) {}

  void pump(const lod::RemoteMeshBakers::Take& take, const lod::RemoteMeshBakers::Deliver& deliver) {
    while (auto e = world_.poll()) {
      std::vector<uint8_t> message = world_.receive(*e);
      uint32_t mesh = numberOf(message);
      if (e->tag == kReady) {
        free_[size_t(e->source)] = mesh;
      } else if (e->tag == kResult || e->tag == kFailure) {
        ++free_[size_t(e->source)];
        units_[size_t(e->source)].push_back(mesh);
        if (e->tag == kResult)
          deliver(mesh, std::vector<uint8_t>(message.begin() + 4, message.end()));
        else
          deliver(mesh, Error{std::string(message.begin() + 4, message.end())});
      }
    }
    for (int r = 1; r < world_.size(); ++r)
      while (free_[size_t(r)] > 0) {
        std::optional<uint32_t> mesh = take();
        if (!mesh) return;
        --free_[size_t(r)];
        world_.send(r, kAssign, numberBytes(*mesh));
      }
  }

  // Every worker told to stop; what they still send is dropped until each says Stopped.
  void stop() {
    for (int r = 1; r < world_.size(); ++r) world_.send(r, kStop, {});
    for (int left = world_.size() - 1; left > 0;) {
      auto e = world_.poll();
      if (!e) {
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
        continue;
      }
      world_.receive(*e);
      left -= e->tag == kStopped;
    }
  }

  std::vector<std::vector<uint32_t>>& units() { return units_; }

private:
  const World& world_;
  std::vector<uint32_t> free_;
  std::vector<std::vector<uint32_t>> units_;
};

// Rank 0's side of a resumable bake: the journal, continued after the meshes it records (checked
// against the partial output and spool by lod::checkStreamResume), and what the lod bake resumes.
struct ResumableBake {
  Journal journal;
  lod::StreamResume resume;
};

Result<ResumableBake> openResumable(const lod::MeshSource& source, const std::string& path,
                                    const lod::BuildConfig& config, const lod::LodWriteOptions& write,
                                    const BakeRun& run) {
  if (source.key.empty()) return makeError(path, "this scene's bake cannot be resumed");
  const uint32_t meshCount = uint32_t(source.layout.meshes.size());
  const uint64_t print = streamFingerprint(source, config, write);
  auto read = readJournal(run.journal, print, meshCount);
  if (!read) return read.error();
  std::vector<std::vector<uint8_t>> records;
  for (JournalEntry& e : read->entries) {
    if (e.unit != records.size()) // meshes are written, so journaled, in order
      return makeError(run.journal, "damaged bake journal (mesh " + std::to_string(e.unit) + " recorded after mesh " +
                                        std::to_string(records.size()) + " was not): remove it and bake again");
    records.push_back(std::move(e.bytes));
  }
  auto resume = lod::checkStreamResume(path, meshCount, records);
  if (!resume) return resume.error();
  auto journal = Journal::open(run.journal, print, meshCount, read->validBytes);
  if (!journal) return journal.error();
  return ResumableBake{std::move(journal).value(), std::move(resume).value()};
}

// Rank 0, after the bake: a resumable bake's files go once the output is written or the bake failed
// with an error (a kill never gets here); a bake without resume removes an earlier one's at the end.
void closeRun(const Status& baked, const std::string& path, const BakeRun& run,
              std::optional<ResumableBake>& resumable) {
  if (resumable) {
    resumable->journal.remove();
    if (!baked) lod::removeStreamFiles(path);
  } else if (baked && !run.journal.empty()) {
    ::unlink(run.journal.c_str());
    lod::removeStreamFiles(path);
  }
}

} // namespace

uint64_t streamFingerprint(const lod::MeshSource& source, const lod::BuildConfig& config,
                           const lod::LodWriteOptions& write) {
  Hasher h;
  h.add(std::span<const char>(std::string_view("mirage build gen:many: stream journal")));
  h.add(lod::kStreamRecordVersion), h.add(lod::kDagCodecVersion), h.add(lod::kPagedChunkVersion);
  h.add(lod::kPageCodecVersion);
  h.add(std::span<const char>(source.key));
  h.add(config.clusterTriangles), h.add(config.clusterVertices), h.add(config.groupClusters);
  h.add(config.coarseGroupsFromLevel), h.add(config.coarserGroupsFromLevel), h.add(config.stuckRatio);
  h.add(config.normalWeight), h.add(config.rootClusters), h.add(config.maxLevels);
  h.add(uint8_t(write.paged)), h.add(write.dag.positionBits), h.add(write.pages.pageBytes);
  h.add(uint64_t(source.layout.meshes.size()));
  for (const Mesh& m : source.layout.meshes) h.add(std::span<const char>(m.name));
  return h.digest();
}

Status bakeLodFile(const World& world, const lod::MeshSource& source, const std::string& path, lod::BuildConfig config,
                   const lod::LodWriteOptions& write, const lod::StreamBakeOptions& options,
                   lod::StreamBakeReport* report, ScheduleReport* ranks, const lod::BuildProgress& progress,
                   const BakeRun& run) {
  // Rank 0 opens the journal first: a refused one stops the bake before any rank bakes.
  std::optional<ResumableBake> resumable;
  lod::StreamJournal journal;
  Status opened = Ok{};
  if (world.root() && run.resume && !run.journal.empty()) {
    auto r = openResumable(source, path, config, write, run);
    if (r) {
      resumable.emplace(std::move(r).value());
      journal.resume = std::move(resumable->resume);
      journal.commit = [&](uint32_t mesh, std::span<const uint8_t> record) {
        return resumable->journal.append(mesh, record);
      };
    } else {
      opened = r.error();
    }
  }
  const lod::StreamJournal* resume = resumable ? &journal : nullptr;
  lod::StreamBakeReport mesh;
  if (world.size() == 1) {
    std::vector<uint32_t> local;
    auto t0 = Clock::now();
    if (!opened) return opened;
    Status s = lod::bakeLodFile(source, path, config, write, options, &mesh, progress, nullptr, &local, resume);
    closeRun(s, path, run, resumable);
    if (s && ranks) {
      ranks->ranks.assign(1, RankReport{local, 0.0});
      ranks->resumedUnits = mesh.resumedMeshes;
      ranks->seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    }
    if (s && report) *report = mesh;
    return s;
  }
  if (config.threads == 0) config.threads = world.threadShare();
  if (!world.root()) return world.agree(work(world, source, path, config, write, options));
  RemoteRanks remote(world);
  lod::RemoteMeshBakers bakers{[&](const auto& take, const auto& deliver) { remote.pump(take, deliver); }};
  std::vector<uint32_t> local;
  auto t0 = Clock::now();
  Status mine = opened
                    ? lod::bakeLodFile(source, path, config, write, options, &mesh, progress, &bakers, &local, resume)
                    : opened;
  remote.stop();
  if (opened) closeRun(mine, path, run, resumable);
  if (Status all = world.agree(mine); !all) return all;
  if (report) *report = mesh;
  if (ranks) {
    ranks->ranks.assign(size_t(world.size()), RankReport{});
    ranks->ranks[0].units = std::move(local);
    for (int r = 1; r < world.size(); ++r) ranks->ranks[size_t(r)].units = std::move(remote.units()[size_t(r)]);
    ranks->resumedUnits = mesh.resumedMeshes;
    ranks->seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  }
  return Ok{};
}

} // namespace mirage::bake
