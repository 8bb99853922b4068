#include "mirage/bake/world.h"

#include <sched.h>

#include <algorithm>
#include <cassert>
#include <chrono>
#include <cstdlib>
#include <string>
#include <thread>

#ifdef MIRAGE_HAVE_MPI
#include <mpi.h>
#endif

namespace mirage::bake {

namespace {

// The job size an MPI launcher gives its processes (Open MPI, MPICH/Hydra and Slurm's PMI, PMIx), or 0.
int launchedSize() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE"})
    if (const char* v = std::getenv(name)) return std::max(1, std::atoi(v));
  if (std::getenv("PMIX_RANK")) return 1; // PMIx without a size variable: ask MPI
  return 0;
}

#ifdef MIRAGE_HAVE_MPI
// MPI counts are ints: messages go as their length, then pieces of at most 1 GiB.
constexpr size_t kPiece = size_t(1) << 30;

// Waits for a request without spinning: MPI's blocking calls poll at full speed, which on a host
// of several ranks takes the cores the others bake with (rank 0 writing the output while the rest
// wait, an oversubscribed test run). A wait adds at most the nap to a message's latency.
constexpr auto kNap = std::chrono::microseconds(200);
void waitQuietly(MPI_Request& request) {
  for (int done = 0;;) {
    MPI_Test(&request, &done, MPI_STATUS_IGNORE);
    if (done) return;
    std::this_thread::sleep_for(kNap);
  }
}
#endif

} // namespace

Result<World> World::join() {
  World w;
  int launched = launchedSize();
  if (launched == 0) return w;
#ifdef MIRAGE_HAVE_MPI
  int initialized = 0, finalized = 0;
  MPI_Initialized(&initialized);
  MPI_Finalized(&finalized);
  if (finalized) return Error{"MPI was finalized already in this process"};
  if (!initialized) {
    // Funneled: only the main thread calls MPI (rank 0's baking thread and TBB's never do).
    int provided = 0;
    if (MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS)
      return Error{"MPI_Init_thread failed"};
    w.ownsMpi_ = true;
  }
  MPI_Comm_rank(MPI_COMM_WORLD, &w.rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &w.size_);
  MPI_Comm local;
  MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, w.rank_, MPI_INFO_NULL, &local);
  MPI_Comm_rank(local, &w.localRank_);
  MPI_Comm_size(local, &w.localSize_);
  MPI_Comm_free(&local);
  return w;
#else
  if (launched > 1)
    return Error{"started as " + std::to_string(launched) +
                 " processes, but this mirage was built without MPI (configure with -DMIRAGE_MPI=ON)"};
  return w;
#endif
}

World::World(World&& other) noexcept
    : rank_(other.rank_), size_(other.size_), localRank_(other.localRank_), localSize_(other.localSize_),
      ownsMpi_(other.ownsMpi_) {
  other.ownsMpi_ = false;
}

World::~World() {
#ifdef MIRAGE_HAVE_MPI
  if (ownsMpi_) MPI_Finalize();
#endif
}

unsigned World::threadShare() const {
  unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  unsigned share = std::max(1u, cores / unsigned(std::max(1, localSize_)));
  // A launcher may bind the rank to fewer cores (Open MPI binds each of at most two ranks to one
  // core by default): more threads than those would only take turns.
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) == 0) share = std::min(share, unsigned(std::max(1, CPU_COUNT(&set))));
  return share;
}

Status World::agree(const Status& local) const {
  if (size_ == 1) return local;
#ifdef MIRAGE_HAVE_MPI
  int mine = local ? size_ : rank_, first = size_;
  MPI_Request request;
  MPI_Iallreduce(&mine, &first, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD, &request);
  waitQuietly(request);
  if (first == size_) return Ok{};
  std::string message = rank_ == first ? local.error().message : std::string();
  uint64_t length = message.size();
  MPI_Ibcast(&length, 1, MPI_UINT64_T, first, MPI_COMM_WORLD, &request);
  waitQuietly(request);
  message.resize(length);
  MPI_Ibcast(message.data(), int(length), MPI_CHAR, first, MPI_COMM_WORLD, &request);
  waitQuietly(request);
  return Error{message};
#else
  return local;
#endif
}

void World::send(int to, int tag, std::span<const uint8_t> bytes) const {
  assert(size_ > 1 && to != rank_);
#ifdef MIRAGE_HAVE_MPI
  uint64_t length = bytes.size();
  MPI_Send(&length, 1, MPI_UINT64_T, to, tag, MPI_COMM_WORLD);
  for (size_t at = 0; at < bytes.size(); at += kPiece)
    MPI_Send(bytes.data() + at, int(std::min(kPiece, bytes.size() - at)), MPI_BYTE, to, tag, MPI_COMM_WORLD);
#else
  (void)to, (void)tag, (void)bytes;
#endif
}

std::optional<Envelope> World::poll() const {
#ifdef MIRAGE_HAVE_MPI
  if (size_ == 1) return std::nullopt;
  int flag = 0;
  MPI_Status status;
  MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &status);
  if (!flag) return std::nullopt;
  return Envelope{status.MPI_SOURCE, status.MPI_TAG};
#else
  return std::nullopt;
#endif
}

Envelope World::wait(int source) const {
  assert(size_ > 1);
#ifdef MIRAGE_HAVE_MPI
  MPI_Status status;
  for (int flag = 0;;) { // MPI_Probe would spin (waitQuietly)
    MPI_Iprobe(source, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &status);
    if (flag) return Envelope{status.MPI_SOURCE, status.MPI_TAG};
    std::this_thread::sleep_for(kNap);
  }
#else
  return Envelope{source, 0};
#endif
}

std::vector<uint8_t> World::receive(const Envelope& from) const {
  std::vector<uint8_t> bytes;
#ifdef MIRAGE_HAVE_MPI
  uint64_t length = 0;
  MPI_Recv(&length, 1, MPI_UINT64_T, from.source, from.tag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  bytes.resize(length);
  for (size_t at = 0; at < bytes.size(); at += kPiece)
    MPI_Recv(bytes.data() + at, int(std::min(kPiece, bytes.size() - at)), MPI_BYTE, from.source, from.tag,
             MPI_COMM_WORLD, MPI_STATUS_IGNORE);
#else
  (void)from;
#endif
  return bytes;
}

} // namespace mirage::bake
