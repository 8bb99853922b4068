#pragma once
// The processes of one bake: MPI's world when Mirage was started by mpirun (or another MPI
// launcher) and built with MPI (CMake option MIRAGE_MPI), else this process alone. The only place
// MPI is called (src/bake/world.cpp); everything above speaks of ranks and byte messages.
// docs/bake.md.
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "mirage/core/result.h"

namespace mirage::bake {

// A message waiting to be received: who sent it and its tag.
struct Envelope {
  int source = 0;
  int tag = 0;
};

class World {
public:
  // Joins the job this process was launched in. MPI is initialized only under an MPI launcher
  // (its environment names the job size), so a plain `mirage build` never loads it; the destructor
  // finalizes it. Error: several processes launched by a Mirage built without MPI (each would bake
  // and write the whole output).
  static Result<World> join();
  World(World&& other) noexcept;
  World& operator=(World&&) = delete;
  World(const World&) = delete;
  ~World();

  int rank() const { return rank_; }
  int size() const { return size_; }
  bool root() const { return rank_ == 0; }
  // Rank among the processes on this host and their count: which GPU a rank takes, and its share of
  // the host's cores.
  int localRank() const { return localRank_; }
  int localSize() const { return localSize_; }
  // Worker threads for this process: the host's hardware threads over the ranks on it, at most the
  // cores the process is bound to, at least 1.
  unsigned threadShare() const;

  // Collective: every rank passes its own status; every rank gets Ok, or the error of the lowest
  // failing rank (so one rank can print it and all exit non-zero). Waits napping, not spinning.
  Status agree(const Status& local) const;

  // Point to point, any size (sent in pieces under MPI's int counts). Messages from one rank to
  // another arrive in the order sent. Only between ranks of a world of several.
  void send(int to, int tag, std::span<const uint8_t> bytes) const;
  // The next waiting message from any rank, if one is there (never blocks).
  std::optional<Envelope> poll() const;
  // Blocks (napping, not spinning) until a message from `source` is there.
  Envelope wait(int source) const;
  // Receives the message `poll` or `wait` announced.
  std::vector<uint8_t> receive(const Envelope& from) const;

private:
  World() = default;
  int rank_ = 0, size_ = 1, localRank_ = 0, localSize_ = 1;
  bool ownsMpi_ = false; // this object initialized MPI and finalizes it
};

} // namespace mirage::bake
