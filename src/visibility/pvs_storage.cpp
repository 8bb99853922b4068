// 'PVS ' chunk encoding (pvs_storage.h).
//
// Payload: u32 version, u64 sceneTriangles, varint cellCount, then per cell u8 shape and 9 floats
// (position, size, rotation), then per cell: u8 mode (0 full, 1 difference), [varint reference
// cell], varint rawBytes, varint storedBytes, storedBytes of zstd frame. The decompressed stream is
// varint count + delta-coded IDs (full), or the same for the added IDs then the removed IDs.
#include <algorithm>
#include <iterator>
#include <memory>

#include <nlohmann/json.hpp>
#include <tbb/parallel_for.h>
#include <zstd.h>

#include "mirage/asset/bytes.h"
#include "mirage/asset/container.h"
#include "mirage/visibility/pvs_storage.h"
#include "mirage/visibility/ray_backend.h"

namespace mirage::vis {

namespace {

void putIds(asset::ByteWriter& w, std::span<const uint32_t> ids) {
  w.writeVarint(ids.size());
  for (size_t i = 0; i < ids.size(); ++i) w.writeVarint(i == 0 ? ids[0] : ids[i] - ids[i - 1] - 1);
}

bool getIds(asset::ByteReader& r, uint64_t limit, std::vector<uint32_t>& out) {
  uint64_t n = 0;
  // Every ID takes at least one byte, so the count is bounded by the bytes left.
  if (!r.readCount(n, std::min<uint64_t>(limit, r.remaining()), "ID count")) return false;
  out.resize(n);
  uint64_t prev = 0;
  for (uint64_t i = 0; i < n; ++i) {
    uint64_t d = 0;
    if (!r.readVarint(d)) return false;
    uint64_t id = i == 0 ? d : prev + d + 1;
    if (d >= limit || id >= limit) return false;
    out[i] = uint32_t(id);
    prev = id;
  }
  return true;
}

std::vector<uint8_t> compress(const std::vector<uint8_t>& raw, int level) {
  std::vector<uint8_t> out(ZSTD_compressBound(raw.size()));
  size_t n = ZSTD_compress(out.data(), out.size(), raw.data(), raw.size(), level);
  out.resize(ZSTD_isError(n) ? 0 : n);
  return out;
}

std::vector<uint8_t> encodeFull(std::span<const uint32_t> ids) {
  asset::ByteWriter w;
  putIds(w, ids);
  return w.take();
}

std::vector<uint8_t> encodeDiff(std::span<const uint32_t> ids, std::span<const uint32_t> ref) {
  std::vector<uint32_t> added, removed;
  std::set_difference(ids.begin(), ids.end(), ref.begin(), ref.end(), std::back_inserter(added));
  std::set_difference(ref.begin(), ref.end(), ids.begin(), ids.end(), std::back_inserter(removed));
  asset::ByteWriter w;
  putIds(w, added);
  putIds(w, removed);
  return w.take();
}

// IDs in one sorted set and not the other, counted by a merge walk (no allocation).
size_t changedIds(std::span<const uint32_t> a, std::span<const uint32_t> b) {
  size_t i = 0, j = 0, common = 0;
  while (i < a.size() && j < b.size()) {
    if (a[i] < b[j])
      ++i;
    else if (b[j] < a[i])
      ++j;
    else
      ++common, ++i, ++j;
  }
  return a.size() + b.size() - 2 * common;
}

} // namespace

std::vector<uint8_t> encodePvs(const PvsData& pvs, const PvsEncodeOptions& options, PvsEncodeStats* stats) {
  asset::ByteWriter w;
  w.write(kPvsChunkVersion);
  w.write(pvs.sceneTriangles);
  w.writeVarint(pvs.cells.size());
  for (const ViewCell& c : pvs.cells) {
    w.write(uint8_t(c.shape));
    for (glm::vec3 v : {c.position, c.size, c.rotation}) w.write(v);
  }
  // Choosing a reference compares sizes at a fast zstd level, and only the chosen stream of each cell
  // is compressed at options.zstdLevel, in parallel: trying every candidate at level 19, one cell
  // after another, cost about 130 ms a cell of 10 k IDs on a 2-core VM (docs/visibility.md).
  constexpr int kTrialLevel = 3;
  size_t n = pvs.cells.size();
  std::vector<std::vector<uint8_t>> raw(n);
  std::vector<size_t> fullTrial(n);
  tbb::parallel_for(size_t(0), n, [&](size_t i) {
    raw[i] = encodeFull(pvs.triangles[i]);
    fullTrial[i] = compress(raw[i], kTrialLevel).size();
  });
  // In cell order (a difference refers to an earlier full cell): of the last searchWindow full
  // cells the one with the fewest changed IDs, kept when its difference compresses smaller.
  std::vector<int64_t> ref(n, -1);
  if (options.differences) {
    std::vector<size_t> fullCells;
    for (size_t i = 0; i < n; ++i) {
      size_t fewest = SIZE_MAX;
      int64_t candidate = -1;
      for (size_t k = fullCells.size(); k-- > 0 && fullCells.size() - k <= options.searchWindow;)
        if (size_t c = changedIds(pvs.triangles[i], pvs.triangles[fullCells[k]]); c < fewest)
          fewest = c, candidate = int64_t(fullCells[k]);
      if (candidate >= 0 && fewest < pvs.triangles[i].size()) {
        std::vector<uint8_t> diffRaw = encodeDiff(pvs.triangles[i], pvs.triangles[size_t(candidate)]);
        if (compress(diffRaw, kTrialLevel).size() < fullTrial[i]) ref[i] = candidate, raw[i] = std::move(diffRaw);
      }
      if (ref[i] < 0) fullCells.push_back(i);
    }
  }
  std::vector<std::vector<uint8_t>> stored(n);
  tbb::parallel_for(size_t(0), n, [&](size_t i) { stored[i] = compress(raw[i], options.zstdLevel); });
  for (size_t i = 0; i < n; ++i) {
    size_t start = w.size();
    w.write(uint8_t(ref[i] < 0 ? 0 : 1));
    if (ref[i] >= 0) w.writeVarint(uint64_t(ref[i]));
    w.writeVarint(raw[i].size());
    w.writeVarint(stored[i].size());
    w.writeBytes(stored[i]);
    if (stats) {
      stats->cellBytes.push_back(w.size() - start);
      stats->differenceCells += ref[i] >= 0;
    }
  }
  if (stats) stats->totalBytes = w.size();
  return w.take();
}

Result<PvsData> decodePvs(std::span<const uint8_t> bytes, const std::string& file) {
  auto fail = [&](const std::string& problem) { return makeError(file, "PVS: " + problem); };
  asset::ByteReader r(bytes, file);
  uint32_t version = 0;
  PvsData pvs;
  uint64_t cellCount = 0;
  if (!r.read(version)) return r.error();
  if (version != kPvsChunkVersion) return fail("unsupported version " + std::to_string(version));
  // 41 bytes of cell header + at least 3 bytes of payload header per cell bound the count.
  if (!r.read(pvs.sceneTriangles) || !r.readCount(cellCount, r.remaining() / 44, "cell count")) return r.error();
  if (pvs.sceneTriangles > uint64_t(kNoHit)) return fail("scene triangle count out of range");
  for (uint64_t i = 0; i < cellCount; ++i) {
    ViewCell c;
    uint8_t shape = 0;
    if (!r.read(shape) || !r.read(c.position) || !r.read(c.size) || !r.read(c.rotation)) return r.error();
    if (shape > 1) return fail("cell " + std::to_string(i) + ": bad shape " + std::to_string(shape));
    c.shape = CellShape(shape);
    if (auto ok = validateCell(c, file + ": PVS: cell " + std::to_string(i)); !ok) return ok.error();
    pvs.cells.push_back(c);
  }
  std::vector<bool> full;
  for (uint64_t i = 0; i < cellCount; ++i) {
    std::string where = "cell " + std::to_string(i) + ": ";
    uint8_t mode = 0;
    uint64_t ref = 0, rawBytes = 0, storedBytes = 0;
    if (!r.read(mode)) return r.error();
    if (mode > 1) return fail(where + "bad mode " + std::to_string(mode));
    if (mode == 1) {
      if (!r.readVarint(ref)) return r.error();
      if (ref >= i || !full[ref]) return fail(where + "bad reference cell " + std::to_string(ref));
    }
    // A varint per ID plus two counts: at most 5 bytes per triangle in the scene, and then some.
    if (!r.readCount(rawBytes, 10 * pvs.sceneTriangles + 20, "raw size") ||
        !r.readCount(storedBytes, r.remaining(), "stored size"))
      return r.error();
    std::vector<uint8_t> stored(storedBytes);
    if (!r.readBytes(stored)) return r.error();
    unsigned long long declared = ZSTD_getFrameContentSize(stored.data(), stored.size());
    if (declared != rawBytes) return fail(where + "zstd frame size does not match");
    // Checked before allocating: a zstd block yields at most 128 KiB and takes at least 4 bytes.
    if (rawBytes / 32768 > storedBytes) return fail(where + "raw size is more than zstd can expand its bytes to");
    std::vector<uint8_t> raw(rawBytes);
    size_t n = ZSTD_decompress(raw.data(), raw.size(), stored.data(), stored.size());
    if (ZSTD_isError(n) || n != rawBytes) return fail(where + "corrupt zstd frame");
    asset::ByteReader ids(raw, file);
    std::vector<uint32_t> a, b;
    if (!getIds(ids, pvs.sceneTriangles, a)) return fail(where + "bad triangle IDs");
    if (mode == 1) {
      if (!getIds(ids, pvs.sceneTriangles, b)) return fail(where + "bad triangle IDs");
      const auto& base = pvs.triangles[ref];
      if (!std::includes(base.begin(), base.end(), b.begin(), b.end()))
        return fail(where + "removes IDs its reference lacks");
      std::vector<uint32_t> kept, merged;
      std::set_difference(base.begin(), base.end(), b.begin(), b.end(), std::back_inserter(kept));
      std::set_union(kept.begin(), kept.end(), a.begin(), a.end(), std::back_inserter(merged));
      if (merged.size() != kept.size() + a.size()) return fail(where + "adds IDs its reference has");
      a = std::move(merged);
    }
    if (ids.remaining() != 0) return fail(where + "trailing bytes");
    full.push_back(mode == 0);
    pvs.triangles.push_back(std::move(a));
  }
  if (r.remaining() != 0) return fail("trailing bytes");
  return pvs;
}

Status savePvs(const std::string& path, const PvsData& pvs, const std::string& sceneSource,
               const PvsEncodeOptions& options, PvsEncodeStats* stats) {
  asset::AssetWriter writer;
  writer.addChunk(asset::chunk::Visibility, encodePvs(pvs, options, stats), /*zstdLevel=*/0);
  nlohmann::json meta;
  meta["pvs_version"] = kPvsChunkVersion;
  meta["scene"] = sceneSource;
  meta["scene_triangles"] = pvs.sceneTriangles;
  meta["cells"] = pvs.cells.size();
  std::string text = meta.dump();
  writer.addChunk(asset::chunk::Meta, std::span(reinterpret_cast<const uint8_t*>(text.data()), text.size()));
  return writer.write(path);
}

Result<PvsData> loadPvs(const std::string& path) {
  auto reader = asset::AssetReader::open(path);
  if (!reader) return reader.error();
  auto bytes = reader->readChunk(asset::chunk::Visibility);
  if (!bytes) return bytes.error();
  return decodePvs(*bytes, path);
}

} // namespace mirage::vis
