// The .mrg 'SURF' chunk: version 3 stores the cloud as blocks in prefix order (asset/blocks.h), so
// any byte prefix decodes to a surfel prefix; versions 1 and 2 (one flat array) are still read.
#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>

#include <fmt/format.h>

#include "mirage/asset/blocks.h"
#include "mirage/asset/container.h"
#include "mirage/surfels/surfel_io.h"

namespace mirage::surfels {

namespace {

// 1 had no mesh word; 2 added it; 3 cut the surfels into blocks (the header rides in the index).
constexpr uint32_t kFlatVersion = 2;
constexpr uint32_t kBlockedVersion = 3;
constexpr size_t kSurfelRecord = sizeof(Surfel) + sizeof(float); // a surfel and its prefix radius

struct SurfelChunkHeader {
  uint32_t version = kBlockedVersion;
  uint32_t count = 0;
  uint32_t referenceCount = 0;
  uint32_t pad = 0;
  float boxMin[3];
  float boxMax[3];
  float referenceMeanSpacing = 0.0f;
  float referenceMedianSpacing = 0.0f;
};
static_assert(sizeof(SurfelChunkHeader) == 48, "SURF chunk header layout");
constexpr size_t kMeshWords = 8; // uint32 mesh, uint32 pad (versions 2 and 3)

template <class T> void append(std::vector<uint8_t>& out, const T* data, size_t count) {
  // resize + memcpy rather than insert: GCC 12 warns falsely (-Wstringop-overflow) on the insert.
  size_t at = out.size(), bytes = count * sizeof(T);
  out.resize(at + bytes);
  if (bytes) std::memcpy(out.data() + at, data, bytes);
}

// Header and mesh word of a cloud, as versions 2 and 3 store them.
std::vector<uint8_t> encodeHeader(const SurfelCloud& c, uint32_t mesh, uint32_t version) {
  SurfelChunkHeader h;
  h.version = version;
  h.count = uint32_t(c.size());
  h.referenceCount = c.referenceCount;
  for (int a = 0; a < 3; ++a) h.boxMin[a] = c.box.min[a], h.boxMax[a] = c.box.max[a];
  h.referenceMeanSpacing = c.referenceMeanSpacing;
  h.referenceMedianSpacing = c.referenceMedianSpacing;
  std::vector<uint8_t> out;
  append(out, &h, 1);
  const uint32_t meshWords[2] = {mesh, 0};
  append(out, meshWords, 2);
  return out;
}

// The numbers renderers compute with: the quantization box and the spacings (the surfels themselves
// are integers inside the box, any value valid). Fills everything of `out` but the surfels.
Status decodeHeader(const SurfelChunkHeader& h, MeshSurfels& out, const std::string& context) {
  for (int a = 0; a < 3; ++a)
    if (!std::isfinite(h.boxMin[a]) || !std::isfinite(h.boxMax[a]) || (h.count > 0 && !(h.boxMin[a] <= h.boxMax[a])))
      return makeError(context, "SURF chunk has a NaN, infinite or inverted box");
  if (!std::isfinite(h.referenceMeanSpacing) || !std::isfinite(h.referenceMedianSpacing) ||
      h.referenceMeanSpacing < 0.0f || h.referenceMedianSpacing < 0.0f || h.referenceCount > h.count)
    return makeError(context, "SURF chunk has bad reference spacing statistics");
  SurfelCloud& c = out.cloud;
  c.box.min = {h.boxMin[0], h.boxMin[1], h.boxMin[2]};
  c.box.max = {h.boxMax[0], h.boxMax[1], h.boxMax[2]};
  c.referenceCount = h.referenceCount;
  c.referenceMeanSpacing = h.referenceMeanSpacing;
  c.referenceMedianSpacing = h.referenceMedianSpacing;
  return Ok{};
}

// Appends `n` surfels then `n` radii read from `bytes` to the cloud; radii must be finite and >= 0.
Status appendRecords(std::span<const uint8_t> surfels, std::span<const uint8_t> radii, size_t n, SurfelCloud& c,
                     const std::string& context, const std::string& where) {
  size_t at = c.surfels.size();
  c.surfels.resize(at + n);
  c.radii.resize(at + n);
  if (n) std::memcpy(c.surfels.data() + at, surfels.data(), n * sizeof(Surfel));
  if (n) std::memcpy(c.radii.data() + at, radii.data(), n * sizeof(float));
  for (size_t i = at; i < at + n; ++i)
    if (!std::isfinite(c.radii[i]) || c.radii[i] < 0.0f)
      return makeError(context, fmt::format("SURF chunk{}: radius {} is negative, NaN or infinite", where, i));
  return Ok{};
}

Result<MeshSurfels> decodeFlat(std::span<const uint8_t> bytes, const std::string& file) {
  SurfelChunkHeader h;
  if (bytes.size() < sizeof(h)) return makeError(file, "SURF chunk is shorter than its header");
  std::memcpy(&h, bytes.data(), sizeof(h));
  if (h.version != 1 && h.version != kFlatVersion)
    return makeError(file, fmt::format("SURF chunk version {} is not supported (this build reads 1 to {}; rewrite the "
                                       "file with this build's mirage surfels)",
                                       h.version, kBlockedVersion));
  size_t headerBytes = sizeof(h) + (h.version >= 2 ? kMeshWords : 0);
  size_t expected = headerBytes + size_t(h.count) * kSurfelRecord;
  if (bytes.size() != expected)
    return makeError(file, fmt::format("SURF chunk has {} bytes, {} surfels need {}", bytes.size(), h.count, expected));
  MeshSurfels out;
  if (Status s = decodeHeader(h, out, file); !s) return s.error();
  if (h.version >= 2) std::memcpy(&out.mesh, bytes.data() + sizeof(h), 4);
  size_t surfelBytes = size_t(h.count) * sizeof(Surfel);
  if (Status s = appendRecords(bytes.subspan(headerBytes, surfelBytes), bytes.subspan(headerBytes + surfelBytes),
                               h.count, out.cloud, file, "");
      !s)
    return s.error();
  return out;
}

bool isBlocked(std::span<const uint8_t> bytes) {
  uint32_t magic = 0;
  if (bytes.size() >= 4) std::memcpy(&magic, bytes.data(), 4);
  return magic == asset::kBlockMagic;
}

// The version-3 header from a block index, and the block structure checked against its count: every
// block whole records, the blocks summing to the count. Then the complete blocks' surfels.
Result<SurfelPrefix> decodeBlockedPrefix(const asset::BlockPrefix& p, const std::string& context) {
  SurfelPrefix out;
  out.nextBytes = p.nextBytes;
  if (!p.haveIndex) return out;
  const asset::BlockTable& t = p.table;
  SurfelChunkHeader h;
  if (t.header.size() != sizeof(h) + kMeshWords)
    return makeError(
        context, fmt::format("SURF block index header has {} bytes, not {}", t.header.size(), sizeof(h) + kMeshWords));
  std::memcpy(&h, t.header.data(), sizeof(h));
  if (h.version != kBlockedVersion)
    return makeError(context, fmt::format("SURF chunk version {} in a blocked payload is not supported (this build "
                                          "reads {}; rewrite the file with this build's mirage surfels)",
                                          h.version, kBlockedVersion));
  if (Status s = decodeHeader(h, out.surfels, context); !s) return s.error();
  std::memcpy(&out.surfels.mesh, t.header.data() + sizeof(h), 4);
  uint64_t total = 0;
  for (size_t b = 0; b < t.blocks.size(); ++b) {
    if (t.blocks[b].rawBytes % kSurfelRecord != 0)
      return makeError(context, fmt::format("SURF block {} has {} bytes, not whole {}-byte surfels", b,
                                            t.blocks[b].rawBytes, kSurfelRecord));
    total += t.blocks[b].rawBytes / kSurfelRecord;
  }
  if (total != h.count)
    return makeError(context, fmt::format("SURF blocks hold {} surfels, the header says {}", total, h.count));
  out.haveIndex = true;
  out.total = h.count;
  SurfelCloud& c = out.surfels.cloud;
  size_t prefix = 0;
  for (const std::vector<uint8_t>& raw : p.raw) prefix += raw.size() / kSurfelRecord;
  c.surfels.reserve(prefix);
  c.radii.reserve(prefix);
  for (size_t b = 0; b < p.raw.size(); ++b) {
    std::span<const uint8_t> raw = p.raw[b];
    size_t n = raw.size() / kSurfelRecord;
    if (Status s = appendRecords(raw.first(n * sizeof(Surfel)), raw.subspan(n * sizeof(Surfel)), n, c, context,
                                 fmt::format(" block {}", b));
        !s)
      return s.error();
  }
  return out;
}

} // namespace

Status checkSurfelBlockConfig(const SurfelBlockConfig& c) {
  auto power = [](uint32_t v) { return v >= 256 && v <= (1u << 20) && std::has_single_bit(v); };
  if (!power(c.firstSurfels) || !power(c.maxSurfels) || c.firstSurfels > c.maxSurfels)
    return Error{fmt::format("{}:{}: block sizes must be powers of two with 256 <= first <= max <= {}", c.firstSurfels,
                             c.maxSurfels, 1u << 20)};
  return Ok{};
}

Result<SurfelBlockConfig> parseSurfelBlockConfig(const std::string& text) {
  SurfelBlockConfig config;
  auto number = [](std::string_view s, uint32_t& out) {
    auto r = std::from_chars(s.data(), s.data() + s.size(), out);
    return !s.empty() && r.ec == std::errc() && r.ptr == s.data() + s.size();
  };
  std::string_view view(text);
  size_t colon = view.find(':');
  if (colon == std::string_view::npos || !number(view.substr(0, colon), config.firstSurfels) ||
      !number(view.substr(colon + 1), config.maxSurfels))
    return Error{fmt::format("expected FIRST:MAX surfels per block, got '{}'", text)};
  if (Status s = checkSurfelBlockConfig(config); !s) return s.error();
  return config;
}

std::vector<uint32_t> surfelBlockEnds(uint32_t count, const SurfelBlockConfig& config) {
  std::vector<uint32_t> ends;
  uint64_t end = 0;
  while (end < count) {
    // The first block, then each as large as all before it, up to the largest size.
    uint64_t size = end == 0 ? config.firstSurfels : std::min<uint64_t>(end, config.maxSurfels);
    end = std::min<uint64_t>(end + std::max<uint64_t>(size, 1), count);
    ends.push_back(uint32_t(end));
  }
  return ends;
}

Result<std::vector<uint8_t>> encodeSurfelChunk(const SurfelCloud& c, uint32_t mesh, const SurfelBlockConfig& config) {
  if (Status s = checkSurfelBlockConfig(config); !s) return s.error();
  std::vector<uint8_t> header = encodeHeader(c, mesh, kBlockedVersion);
  std::vector<asset::EncodedBlock> blocks;
  std::vector<uint8_t> raw;
  uint32_t begin = 0;
  for (uint32_t end : surfelBlockEnds(uint32_t(c.size()), config)) {
    raw.clear();
    append(raw, c.surfels.data() + begin, end - begin);
    for (uint32_t i = begin; i < end; ++i) {
      float r = i < c.radii.size() ? c.radii[i] : 0.0f;
      append(raw, &r, 1);
    }
    Result<asset::EncodedBlock> b = asset::encodeBlock(raw, config.zstdLevel);
    if (!b) return b.error();
    blocks.push_back(std::move(*b));
    begin = end;
  }
  return asset::assembleBlocks(header, blocks);
}

std::vector<uint8_t> encodeSurfelChunkFlat(const SurfelCloud& c, uint32_t mesh) {
  std::vector<uint8_t> out = encodeHeader(c, mesh, kFlatVersion);
  append(out, c.surfels.data(), c.size());
  std::vector<float> radii = c.radii;
  radii.resize(c.size(), 0.0f);
  append(out, radii.data(), radii.size());
  return out;
}

Result<SurfelPrefix> decodeSurfelPrefix(std::span<const uint8_t> bytes, const std::string& file) {
  Result<asset::BlockPrefix> p = asset::decodeBlockPrefix(bytes, file);
  if (!p) return p.error();
  return decodeBlockedPrefix(*p, file);
}

Result<MeshSurfels> decodeSurfelChunkWithMesh(std::span<const uint8_t> bytes, const std::string& file) {
  if (!isBlocked(bytes)) return decodeFlat(bytes, file);
  Result<asset::BlockPrefix> p = asset::decodeBlocks(bytes, file);
  if (!p) return p.error();
  Result<SurfelPrefix> s = decodeBlockedPrefix(*p, file);
  if (!s) return s.error();
  return std::move(s->surfels);
}

Result<SurfelCloud> decodeSurfelChunk(std::span<const uint8_t> bytes, const std::string& file) {
  auto r = decodeSurfelChunkWithMesh(bytes, file);
  if (!r) return r.error();
  return std::move(r->cloud);
}

Result<MeshSurfels> readSurfelChunk(const asset::AssetReader& reader, size_t index) {
  if (index >= reader.chunks().size() || reader.chunks()[index].type != asset::chunk::Surfels)
    return makeError(reader.chunkContext(index), "is not a SURF chunk");
  auto bytes = reader.readChunk(index);
  if (!bytes) return bytes.error();
  std::string context = reader.chunkContext(index);
  // A blocked payload in a flat chunk (or the reverse) would skip the checks its layout has.
  if (isBlocked(*bytes) != reader.chunks()[index].blocked)
    return makeError(context, "SURF payload layout does not match its chunk table entry");
  return decodeSurfelChunkWithMesh(*bytes, context);
}

Status writeSurfelMrg(const std::string& path, const SurfelCloud& cloud, const SurfelBlockConfig& config) {
  MeshSurfels one{kWholeScene, cloud};
  return writeSurfelMrg(path, std::span(&one, 1), config);
}

namespace {
Status addSurfelChunks(asset::AssetWriter& writer, std::span<const MeshSurfels> clouds, const SurfelBlockConfig& config,
                       const std::string& path) {
  for (const MeshSurfels& m : clouds) {
    Result<std::vector<uint8_t>> bytes = encodeSurfelChunk(m.cloud, m.mesh, config);
    if (!bytes) return makeError(path, bytes.error().message);
    writer.addBlockedChunk(asset::chunk::Surfels, std::move(*bytes), config.zstdLevel);
  }
  return Ok{};
}
} // namespace

Status writeSurfelMrg(const std::string& path, std::span<const MeshSurfels> clouds, const SurfelBlockConfig& config) {
  asset::AssetWriter writer;
  if (Status s = addSurfelChunks(writer, clouds, config, path); !s) return s;
  return writer.write(path);
}

Status appendSurfelMrg(const std::string& path, std::span<const MeshSurfels> clouds, const SurfelBlockConfig& config) {
  auto reader = asset::AssetReader::open(path);
  if (!reader) return reader.error();
  asset::AssetWriter writer;
  for (size_t i = 0; i < reader->chunks().size(); ++i) {
    const asset::ChunkInfo& info = reader->chunks()[i];
    if (info.type == asset::chunk::Surfels) continue;
    auto stored = reader->readStoredChunk(i);
    if (!stored) return stored.error();
    writer.addStoredChunk(info, std::move(*stored));
  }
  if (Status s = addSurfelChunks(writer, clouds, config, path); !s) return s;
  return writer.write(path);
}

Result<std::vector<MeshSurfels>> readSurfelMrgAll(const std::string& path) {
  auto reader = asset::AssetReader::open(path);
  if (!reader) return reader.error();
  std::vector<MeshSurfels> out;
  for (size_t i = 0; i < reader->chunks().size(); ++i) {
    if (reader->chunks()[i].type != asset::chunk::Surfels) continue;
    auto m = readSurfelChunk(*reader, i);
    if (!m) return m.error();
    out.push_back(std::move(*m));
  }
  if (out.empty()) return makeError(path, "no SURF chunk");
  return out;
}

Result<SurfelCloud> readSurfelMrg(const std::string& path) {
  auto all = readSurfelMrgAll(path);
  if (!all) return all.error();
  if (all->size() != 1)
    return makeError(
        path, fmt::format("holds {} surfel clouds (one per mesh); read them with readSurfelMrgAll", all->size()));
  return std::move(all->front().cloud);
}

} // namespace mirage::surfels
