#include "fuzz_support.h"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <unistd.h>

#include <tbb/global_control.h>
#include <xxhash.h>

#include "mirage/asset/scene_chunk.h"

namespace mirage::fuzz {

namespace {

// One thread: each input is tiny, so waking TBB's workers costs more than it saves (and, on a busy
// machine, far more); a serial run is also reproducible.
const tbb::global_control oneThread(tbb::global_control::max_allowed_parallelism, 1);

std::filesystem::path makeScratchDir() {
  const char* tmp = std::getenv("TMPDIR");
  std::string pattern = std::string(tmp && *tmp ? tmp : "/tmp") + "/mirage-fuzz-XXXXXX";
  if (!mkdtemp(pattern.data())) {
    std::perror("mirage fuzz: mkdtemp");
    std::abort();
  }
  return pattern;
}

struct ScratchDir {
  std::filesystem::path path = makeScratchDir();
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

} // namespace

const std::filesystem::path& scratchDir() {
  static ScratchDir dir;
  return dir.path;
}

std::filesystem::path writeScratch(const std::string& name, std::span<const uint8_t> bytes) {
  std::filesystem::path path = scratchDir() / name;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  check(bool(out), "cannot write " + path.string());
  return path;
}

std::filesystem::path writeScratch(const std::string& name, std::string_view text) {
  return writeScratch(name, std::span(reinterpret_cast<const uint8_t*>(text.data()), text.size()));
}

void fail(const std::string& what) {
  std::fprintf(stderr, "mirage fuzz: invariant broken: %s\n", what.c_str());
  std::abort();
}

void checkOneLine(const Error& error) {
  static const bool verbose = std::getenv("MIRAGE_FUZZ_VERBOSE") != nullptr; // show why inputs are rejected
  if (verbose) std::fprintf(stderr, "rejected: %s\n", error.message.c_str());
  check(!error.message.empty(), "empty error message");
  check(error.message.find('\n') == std::string::npos, "error message spans lines: " + error.message);
}

void checkImportedScene(const Scene& scene, const std::string& file) {
  Status valid = asset::validateScene(scene, file);
  if (!valid) fail("importer returned a scene validateScene rejects: " + valid.error().message);
  std::vector<uint8_t> bytes = asset::encodeScene(scene);
  Result<Scene> back = asset::decodeScene(bytes, file);
  if (!back) fail("SCEN round trip of an imported scene fails: " + back.error().message);
  check(asset::encodeScene(*back) == bytes, "SCEN round trip of an imported scene changes its bytes");
}

} // namespace mirage::fuzz

#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/surfels/surfel_io.h"
#include "mirage/visibility/pvs_storage.h"

namespace mirage::fuzz {

std::vector<uint8_t> resealBlocks(std::span<const uint8_t> bytes) {
  std::vector<uint8_t> out(bytes.begin(), bytes.end());
  asset::BlockIndexHeader h;
  if (out.size() < sizeof(h)) return out;
  std::memcpy(&h, out.data(), sizeof(h));
  if (h.magic != asset::kBlockMagic) return out;
  uint64_t entries = std::min<uint64_t>(h.blockCount, (out.size() - sizeof(h)) / sizeof(asset::BlockEntry));
  for (uint64_t i = 0; i < entries; ++i) {
    uint8_t* at = out.data() + sizeof(h) + i * sizeof(asset::BlockEntry);
    asset::BlockEntry e;
    std::memcpy(&e, at, sizeof(e));
    if (e.offset > out.size() || e.storedBytes > out.size() - e.offset) continue;
    e.storedHash = XXH3_64bits(out.data() + e.offset, e.storedBytes);
    if (!(e.flags & asset::kBlockZstd)) e.rawHash = e.storedHash;
    std::memcpy(at, &e, sizeof(e));
  }
  uint64_t indexBytes = sizeof(h) + uint64_t(h.blockCount) * sizeof(asset::BlockEntry) + h.headerBytes;
  if (indexBytes <= out.size()) {
    std::vector<uint8_t> index(out.begin(), out.begin() + std::ptrdiff_t(indexBytes));
    std::memset(index.data() + offsetof(asset::BlockIndexHeader, indexHash), 0, sizeof(uint64_t));
    h.indexHash = XXH3_64bits(index.data(), index.size());
    std::memcpy(out.data(), &h, sizeof(h));
  }
  return out;
}

std::filesystem::path writeMrg(const std::string& name, std::span<const Chunk> chunks) {
  asset::AssetWriter w;
  for (const Chunk& c : chunks) {
    // Bytes that form a whole blocked payload go in as a blocked chunk, so the fuzzer reaches the
    // container's blocked paths (index checksum, per-block checks) as well as the chunk decoders.
    std::vector<uint8_t> bytes = resealBlocks(c.bytes);
    Result<asset::BlockTable> table = asset::decodeBlockTable(bytes, "fuzz");
    if (table && table->payloadBytes == bytes.size())
      w.addBlockedChunk(c.type, std::move(bytes), /*zstdLevel=*/0);
    else
      w.addChunk(c.type, c.bytes, /*zstdLevel=*/0);
  }
  std::filesystem::path path = scratchDir() / name;
  Status st = w.write(path.string());
  if (!st) fail("cannot write " + path.string() + ": " + st.error().message);
  return path;
}

std::vector<Chunk> readMrg(const std::filesystem::path& path) {
  Result<asset::AssetReader> r = asset::AssetReader::open(path.string());
  if (!r) fail(r.error().message);
  std::vector<Chunk> chunks;
  for (size_t i = 0; i < r->chunks().size(); ++i) {
    Result<std::vector<uint8_t>> bytes = r->readChunk(i);
    if (!bytes) fail(bytes.error().message);
    chunks.push_back({r->chunks()[i].type, std::move(*bytes)});
  }
  return chunks;
}

const std::vector<Chunk>& lodAssetChunks() {
  static const std::vector<Chunk> chunks = [] {
    io::BlobOptions blob;
    blob.subdivisions = 2;
    lod::BuildConfig config;
    config.threads = 1;
    Result<lod::LodAsset> a = lod::bakeLodAsset(io::generateBlob(blob), config);
    if (!a) fail(a.error().message);
    std::filesystem::path path = scratchDir() / "base.mrg";
    if (Status st = lod::saveLodAsset(path.string(), *a); !st) fail(st.error().message);
    std::vector<Chunk> out = readMrg(path);
    std::filesystem::remove(path);
    return out;
  }();
  return chunks;
}

void checkDag(const lod::ClusterDag& dag) {
  size_t vertices = dag.vertexPosition.size();
  for (uint32_t p : dag.vertexPosition) check(p < dag.positions.size(), "vertex position id out of range");
  check(dag.normals.empty() || dag.normals.size() == vertices, "normal count");
  check(dag.uv0.empty() || dag.uv0.size() == vertices, "uv count");
  for (const lod::Cluster& c : dag.clusters) {
    check(size_t(c.vertexOffset) + c.vertexCount <= dag.clusterVertices.size(), "cluster vertex range");
    check((size_t(c.triangleOffset) + c.triangleCount) * 3 <= dag.clusterIndices.size(), "cluster triangle range");
    for (size_t i = 0; i < size_t(c.triangleCount) * 3; ++i)
      check(dag.clusterIndices[size_t(c.triangleOffset) * 3 + i] < c.vertexCount, "local index out of range");
    for (size_t i = 0; i < c.vertexCount; ++i)
      check(dag.clusterVertices[c.vertexOffset + i] < vertices, "cluster vertex id out of range");
    check(c.group == lod::kNone || c.group < dag.groups.size(), "cluster group id");
    check(c.generatingGroup == lod::kNone || c.generatingGroup < dag.groups.size(), "generating group id");
  }
  for (const lod::Group& g : dag.groups) {
    check(size_t(g.childOffset) + g.childCount <= dag.groupChildren.size(), "group child range");
    check(size_t(g.parentOffset) + g.parentCount <= dag.groupParents.size(), "group parent range");
  }
  for (uint32_t c : dag.groupChildren) check(c < dag.clusters.size(), "group child id");
  for (uint32_t c : dag.groupParents) check(c < dag.clusters.size(), "group parent id");
  for (uint32_t c : dag.roots) check(c < dag.clusters.size(), "root id");
}

void loadEveryWay(const std::filesystem::path& path) {
  std::string file = path.string();
  if (Result<Scene> s = asset::loadScene(file); s) {
    Status valid = asset::validateScene(*s, file);
    if (!valid) fail("loadScene returned a scene validateScene rejects: " + valid.error().message);
  } else {
    checkOneLine(s.error());
  }
  if (Result<lod::LodAsset> a = lod::loadLodAsset(file); a) {
    check(a->dags.size() == a->scene.meshes.size(), "one DAG per mesh");
    for (const lod::ClusterDag& dag : a->dags) checkDag(dag);
    check(a->sourceClusters.empty() || a->sourceClusters.size() == a->dags.size(), "one source map per mesh");
    for (size_t m = 0; m < a->sourceClusters.size(); ++m)
      for (uint32_t c : a->sourceClusters[m])
        check(c == lod::kNone || (c < a->dags[m].clusters.size() && a->dags[m].clusters[c].level == 0),
              "source map names a cluster that is not in level 0");
    Scene level0 = lod::levelZeroScene(*a);
    (void)level0;
  } else {
    checkOneLine(a.error());
  }
  if (Result<std::vector<surfels::MeshSurfels>> s = surfels::readSurfelMrgAll(file); !s) checkOneLine(s.error());
  if (Result<vis::PvsData> p = vis::loadPvs(file); !p) checkOneLine(p.error());
}

} // namespace mirage::fuzz
