#pragma once
// `mirage pvs` on every rank of a World: one work unit per view cell. The cells trace rays through
// the whole scene, so every rank loads it and opens its own ray backend (no unit input); rank 0
// gathers the cells' PVS in cell order: the PvsData the single-process bake gives (a cell's PVS does
// not depend on the thread count). docs/bake.md.
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "mirage/bake/lod_bake.h" // BakeRun
#include "mirage/bake/scheduler.h"
#include "mirage/visibility/gvs.h"
#include "mirage/visibility/view_cell.h"

namespace mirage::bake {

// Bakes one cell on this rank (the caller's method: GVS++, random rays or ID cube maps).
using CellBaker = std::function<vis::CellPvs(uint32_t cell)>;

// What a cell's PVS depends on: the settings (the caller's text: method and configuration), the
// cells and the scene's triangle count.
uint64_t pvsFingerprint(const std::string& settings, const std::vector<vis::ViewCell>& cells, uint64_t sceneTriangles);

// Collective: every rank passes the same cell count and its own bakers, one per lane (cells baked at
// once on this rank, each on its own thread: RayBackend::sibling). Rank 0 gets one CellPvs per
// cell (sorted triangles and statistics; no witnesses or checkpoints), the others an empty vector.
Result<std::vector<vis::CellPvs>> bakeCellPvs(const World& world, size_t cells, uint64_t fingerprint,
                                              std::span<const CellBaker> bakers, const BakeRun& run,
                                              ScheduleReport* report = nullptr, const UnitProgress& progress = {});

} // namespace mirage::bake
