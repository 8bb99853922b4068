#pragma once
// PVS storage: the 'PVS ' chunk of a .mrg file. Per cell, the sorted triangle IDs are delta coded
// (first ID, then gaps minus one) as LEB128 varints and zstd-compressed on their own, so one cell
// decodes without touching the others. A cell may instead be stored as the difference (added and
// removed IDs) against an earlier, fully stored cell when that is smaller: neighbouring cells see
// mostly the same triangles. References are never chained, so any cell decodes in at most two
// steps. Layout and limits: docs/visibility.md.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/visibility/view_cell.h"

namespace mirage::vis {

inline constexpr uint32_t kPvsChunkVersion = 1;

struct PvsData {
  uint64_t sceneTriangles = 0; // every ID is below this
  std::vector<ViewCell> cells;
  std::vector<std::vector<uint32_t>> triangles; // per cell, sorted, unique
};

struct PvsEncodeOptions {
  bool differences = true; // a difference against the previous `searchWindow` full cell with the fewest changes
  uint32_t searchWindow = 8;
  int zstdLevel = 19; // written once, loaded often: spend the time on the smallest encoding
};

struct PvsEncodeStats {
  std::vector<uint64_t> cellBytes; // stored bytes per cell (compressed payload + its header)
  uint32_t differenceCells = 0;
  uint64_t totalBytes = 0; // whole chunk
};

std::vector<uint8_t> encodePvs(const PvsData& pvs, const PvsEncodeOptions& options = {},
                               PvsEncodeStats* stats = nullptr);
// Rejects anything malformed (IDs out of range or unsorted, bad references, bad zstd frames,
// sizes that do not add up); never reads out of bounds. Errors: "<file>: PVS: <problem>".
Result<PvsData> decodePvs(std::span<const uint8_t> bytes, const std::string& fileForErrors);

// A .mrg with the 'PVS ' chunk (stored raw: it is compressed per cell already) and a 'META' JSON
// chunk naming the scene source. Atomic: nothing is written on failure.
Status savePvs(const std::string& path, const PvsData& pvs, const std::string& sceneSource,
               const PvsEncodeOptions& options = {}, PvsEncodeStats* stats = nullptr);
Result<PvsData> loadPvs(const std::string& path);

} // namespace mirage::vis
