#pragma once
// Work units of a bake spread over the ranks of a World: rank 0 plans (which units remain, the
// largest first), hands one unit at a time to whichever rank asks (a dynamic queue: uneven units
// balance themselves), bakes units itself on threads of its own, keeps the journal, and gathers every
// unit's bytes. What a unit is (a mesh, a view cell, a surfel object) is the caller's: the scheduler
// sees numbers and bytes. docs/bake.md.
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "mirage/bake/world.h"
#include "mirage/core/result.h"

namespace mirage::bake {

struct UnitPlan {
  // Per unit, its estimated work (e.g. input triangles): larger units are handed out first, so the
  // last ones to finish are small.
  std::vector<uint64_t> costs;
  // Identifies the bake (what its units depend on: inputs and settings); a journal written for
  // another fingerprint is never resumed.
  uint64_t fingerprint = 0;
  std::string journal; // path of the journal of finished units ("" = none); rank 0 writes it
  bool resume = false; // take the units the journal holds instead of baking them again
};

// What a unit needs, made on rank 0 and sent with it (e.g. the mesh to bake), so the other ranks need
// not import the scene; empty when every rank has what it needs. Called from several threads at once
// (rank 0's own baking threads and its coordinating one): it must only read shared data.
using UnitInput = std::function<std::vector<uint8_t>(uint32_t unit)>;
// Bakes one unit from its input, on whichever rank it was given to; the bytes must not depend on the
// rank or its thread count. Called from one thread at a time per process.
using UnitBaker = std::function<Result<std::vector<uint8_t>>(uint32_t unit, std::span<const uint8_t> input)>;
// On rank 0: (units done, unit count, cost done, total cost), resumed units counted as done.
using UnitProgress = std::function<void(size_t, size_t, uint64_t, uint64_t)>;

struct RankReport {
  std::vector<uint32_t> units; // the units this rank baked, in the order it finished them
  double busySeconds = 0.0;    // time spent in the baker
};

struct ScheduleReport {
  std::vector<RankReport> ranks; // one per rank of the world
  size_t resumedUnits = 0;       // units taken from the journal
  double seconds = 0.0;          // wall time of runUnits on rank 0
};

// Collective: every rank calls it; the plan and `input` matter on rank 0 only (the others may pass
// an empty plan and no input). Rank 0 gets every unit's bytes in unit order
// (and the report); other ranks get an empty vector. Any unit's error (or the journal's) stops the
// handing out, and every rank gets that error; the journal is deleted then, as nothing would
// resume differently. After success the journal stays until the caller removes it (removeJournal)
// once the output is written.
Result<std::vector<std::vector<uint8_t>>> runUnits(const World& world, const UnitPlan& plan, const UnitInput& input,
                                                   const UnitBaker& bake, ScheduleReport* report = nullptr,
                                                   const UnitProgress& progress = {});

// As above with several bakers per rank (lanes), one thread each: a rank bakes up to
// bakers.size() units at once (e.g. two view cells on one GPU, so the device traces one while the
// host works on the other's results). Every baker must give the same bytes for a unit; each is
// called from its own thread only.
Result<std::vector<std::vector<uint8_t>>> runUnits(const World& world, const UnitPlan& plan, const UnitInput& input,
                                                   std::span<const UnitBaker> bakers, ScheduleReport* report = nullptr,
                                                   const UnitProgress& progress = {});

// Rank 0, after the output is written: the journal is no longer needed.
void removeJournal(const World& world, const UnitPlan& plan);

} // namespace mirage::bake
