// Seed maker for the fuzz targets (used by make_seeds.sh):
//   seed_tool chunks in.mrg out_dir   out_dir/<name>.chunks: every chunk as FourCC, uint32 size,
//                                     bytes (fuzz_mrg's input form); out_dir/<name>-<i>.<FOURCC>: each
//                                     chunk's payload alone (the per-chunk targets' input)
//   seed_tool scen in.gltf out.SCEN   an imported scene as a 'SCEN' payload (with geometry and textures,
//                                     which the SCEN of a built asset lacks)
//   seed_tool meshopt-glb out.glb     a quad in a GLB with EXT_meshopt_compression (attributes with
//                                     the octahedral filter, triangle indices), which `mirage gen` cannot write
//   seed_tool stream-messages out_dir one file per stream message type (fuzz_stream_message's input)
//   seed_tool pages in.mrg out_dir    the first mesh's DAG paged at 4 KiB: per page the table and the
//                                     page (fuzz_pages' input)
//   seed_tool stream-journal journal_dir resume_dir
//                                     what a resumable streaming bake (flat and paged) killed after two
//                                     of three meshes leaves: its journal (fuzz_journal's input), and
//                                     the journal's records with the partial output and the spool
//                                     (fuzz_stream_resume's input)
#include <cstdio>
#include <cstring>
#include <fstream>

#include <meshoptimizer.h>

#include "fuzz_support.h"
#include "mirage/asset/scene_chunk.h"
#include "mirage/bake/journal.h"
#include "mirage/bake/lod_stream_bake.h"
#include "mirage/io/generate.h"
#include "mirage/io/import.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/lod/paging.h"
#include "mirage/stream/protocol.h"

using namespace mirage;

namespace {

bool writeFile(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), std::streamsize(bytes.size()));
  return bool(out);
}

int chunks(const std::filesystem::path& in, const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  std::string all;
  std::vector<fuzz::Chunk> list = fuzz::readMrg(in);
  for (size_t i = 0; i < list.size(); ++i) {
    const fuzz::Chunk& c = list[i];
    uint32_t size = uint32_t(c.bytes.size());
    all.append(reinterpret_cast<const char*>(&c.type.code), 4);
    all.append(reinterpret_cast<const char*>(&size), 4);
    std::string payload(c.bytes.begin(), c.bytes.end());
    all += payload;
    std::string type(reinterpret_cast<const char*>(&c.type.code), 4); // "PVS " -> "PVS"
    while (!type.empty() && (type.back() == ' ' || type.back() == '\0')) type.pop_back();
    if (!writeFile(dir / (in.stem().string() + "-" + std::to_string(i) + "." + type), payload)) return 2;
  }
  return writeFile(dir / (in.stem().string() + ".chunks"), all) ? 0 : 2;
}

int scen(const std::filesystem::path& in, const std::filesystem::path& out) {
  Result<Scene> scene = io::importScene(in);
  if (!scene) {
    std::fprintf(stderr, "%s\n", scene.error().message.c_str());
    return 2;
  }
  std::vector<uint8_t> bytes = asset::encodeScene(*scene);
  return writeFile(out, std::string(bytes.begin(), bytes.end())) ? 0 : 2;
}

template <class T> void put(std::string& s, T v) { s.append(reinterpret_cast<const char*>(&v), sizeof v); }

int meshoptGlb(const std::filesystem::path& out) {
  const float pos[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  const float nrm[4][4] = {{0, 0, 1, 0}, {0, 0, 1, 0}, {0.6f, 0, 0.8f, 0}, {0, -0.6f, 0.8f, 0}};
  const unsigned int idx[6] = {0, 1, 2, 0, 2, 3};
  int8_t oct[4][4];
  meshopt_encodeFilterOct(oct, 4, 4, 8, &nrm[0][0]);
  std::string bin;
  auto append = [&](size_t bound, auto encode) {
    size_t at = bin.size();
    bin.resize(at + bound);
    size_t len = encode(reinterpret_cast<unsigned char*>(&bin[at]), bound);
    bin.resize((at + len + 3) / 4 * 4);
    return std::to_string(at) + ", \"byteLength\": " + std::to_string(len);
  };
  std::string p = append(meshopt_encodeVertexBufferBound(4, 12),
                         [&](unsigned char* d, size_t b) { return meshopt_encodeVertexBuffer(d, b, pos, 4, 12); });
  std::string n = append(meshopt_encodeVertexBufferBound(4, 4),
                         [&](unsigned char* d, size_t b) { return meshopt_encodeVertexBuffer(d, b, oct, 4, 4); });
  std::string i = append(meshopt_encodeIndexBufferBound(6, 4),
                         [&](unsigned char* d, size_t b) { return meshopt_encodeIndexBuffer(d, b, idx, 6); });
  auto ext = [](const std::string& range, int stride, int count, const char* mode, const char* filter) {
    return std::string(R"("extensions": {"EXT_meshopt_compression": {"buffer": 0, "byteOffset": )") + range +
           ", \"byteStride\": " + std::to_string(stride) + ", \"count\": " + std::to_string(count) + ", \"mode\": \"" +
           mode + "\", \"filter\": \"" + filter + "\"}}";
  };
  std::string json = R"({"asset": {"version": "2.0"},
"extensionsUsed": ["EXT_meshopt_compression"], "extensionsRequired": ["EXT_meshopt_compression"],
"scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
"meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2}]}],
"accessors": [
 {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]},
 {"bufferView": 1, "componentType": 5120, "normalized": true, "count": 4, "type": "VEC3"},
 {"bufferView": 2, "componentType": 5125, "count": 6, "type": "SCALAR"}],
"buffers": [{"byteLength": )" +
                     std::to_string(bin.size()) +
                     R"(}, {"byteLength": 88, "extensions": {"EXT_meshopt_compression": {"fallback": true}}}],
"bufferViews": [
 {"buffer": 1, "byteOffset": 0, "byteLength": 48, "byteStride": 12, )" +
                     ext(p, 12, 4, "ATTRIBUTES", "NONE") + R"(},
 {"buffer": 1, "byteOffset": 48, "byteLength": 16, "byteStride": 4, )" +
                     ext(n, 4, 4, "ATTRIBUTES", "OCTAHEDRAL") + R"(},
 {"buffer": 1, "byteOffset": 64, "byteLength": 24, )" +
                     ext(i, 4, 6, "TRIANGLES", "NONE") + "}]}";
  json.resize((json.size() + 3) / 4 * 4, ' ');
  std::string glb = "glTF";
  put<uint32_t>(glb, 2);
  put<uint32_t>(glb, uint32_t(12 + 8 + json.size() + 8 + bin.size()));
  put<uint32_t>(glb, uint32_t(json.size()));
  put<uint32_t>(glb, 0x4E4F534Au); // "JSON"
  glb += json;
  put<uint32_t>(glb, uint32_t(bin.size()));
  put<uint32_t>(glb, 0x004E4942u); // "BIN\0"
  glb += bin;
  return writeFile(out, glb) ? 0 : 2;
}

// One of each message type with every optional part present (a Frame with each patch size, a
// colour-only patch, block-only entries, colours, particle looks and particles and an atlas payload;
// the same Frame with zstd patch and particle sections), and an empty Frame.
int streamMessages(const std::filesystem::path& dir) {
  using namespace mirage::stream;
  std::filesystem::create_directories(dir);
  Pose pose;
  pose.sequence = 7;
  pose.clientTimeUs = 123456;
  pose.camera.eye = {0.0f, 1.0f, 4.0f};
  pose.predicted = pose.camera;
  pose.predicted.eye.x = 0.1f;
  pose.viewportWidth = 1280;
  pose.viewportHeight = 720;
  Welcome welcome;
  welcome.sessionId = 42;
  welcome.sceneMin = {-1.0f, -1.0f, -1.0f};
  welcome.sceneMax = {1.0f, 1.0f, 1.0f};
  welcome.atlasWidth = welcome.atlasHeight = 1024;
  welcome.patchCount = 100;
  welcome.maxMessageBytes = 65536;
  Frame frame;
  frame.sequence = 3;
  frame.poseSequence = 7;
  frame.removed = {1, 2};
  for (uint8_t t = 1; t <= 4; ++t) {
    PatchUpdate p;
    p.id = 10 + t;
    p.triangleCount = t == 4 ? 1 : t;
    p.blockLog2 = t == 4 ? kColourOnlyBlock : uint8_t(t + 1);
    p.blockX = t == 4 ? 0 : uint16_t(128 * t);
    for (uint32_t v = 0; v < patchVertexCount(p.triangleCount); ++v) p.positions[v] = {1000 + 40 * v, 7 * t, 500};
    frame.updated.push_back(p);
  }
  PatchUpdate moved; // block-only: the client's own geometry at a new block
  moved.id = 20;
  moved.triangleCount = 2;
  moved.geometry = false;
  moved.blockLog2 = 3;
  moved.blockX = 64;
  moved.blockY = 8;
  frame.updated.push_back(moved);
  moved.id = 21;
  moved.blockLog2 = kColourOnlyBlock;
  moved.blockX = moved.blockY = 0;
  frame.updated.push_back(moved);
  frame.colours = {{14, {200, 100, 50, 255}}, {21, {1, 2, 3, 4}}};
  // Particles: a look with a block, a colour-only look, and a particle of a look held before.
  frame.looks = {{2, 32, 32, 5, {}}, {9, 0, 0, kColourOnlyBlock, {50, 60, 70, 80}}};
  frame.particleOrigin = {-1.0f, 0.0f, 2.0f};
  frame.particleStep = 1e-3f;
  frame.particles = {quantizeParticle({-0.5f, 1.0f, 2.5f}, 0.8f, 1.0f, 0x80ffffffu, 2, frame.particleOrigin, 1e-3f),
                     quantizeParticle({0.5f, 2.0f, 3.0f}, 1.5f, -2.0f, 0x40a0c0e0u, 9, frame.particleOrigin, 1e-3f),
                     quantizeParticle({0.0f, 3.0f, 2.0f}, 0.1f, 0.0f, 0x10101010u, 4, frame.particleOrigin, 1e-3f)};
  Frame zstdFrame = frame;
  zstdFrame.patchCodec = PatchCodec::Zstd;
  zstdFrame.particleCodec = PatchCodec::Zstd;
  frame.atlas = {AtlasCodec::ZstdTiles, 64, 64, {0x28, 0xb5, 0x2f, 0xfd}};
  std::vector<std::pair<std::string, Message>> messages = {
      {"hello", Hello{"token", kCapabilityZstdTiles | kCapabilityH264, 1280, 720, false}},
      {"welcome", welcome},
      {"pose", pose},
      {"frame", frame},
      {"frame_zstd", zstdFrame},
      {"frame_empty", Frame{}},
      {"close", Close{CloseCode::BadToken, "wrong token"}}};
  for (const auto& [name, message] : messages) {
    std::vector<uint8_t> bytes = encodeMessage(message);
    if (!writeFile(dir / (name + ".msg"), std::string(bytes.begin(), bytes.end()))) return 2;
  }
  return 0;
}

int pages(const std::filesystem::path& in, const std::filesystem::path& dir) {
  Result<lod::LodAsset> asset = lod::loadLodAsset(in.string());
  if (!asset || asset->dags.empty()) {
    std::fprintf(stderr, "%s\n", asset ? "no DAG" : asset.error().message.c_str());
    return 2;
  }
  std::filesystem::create_directories(dir);
  lod::PagedDag paged = lod::buildPages(asset->dags[0], lod::PageConfig{.pageBytes = 4096});
  std::vector<uint8_t> table = lod::encodePageTable(paged.table);
  for (uint32_t p = 0; p < paged.pages.size(); ++p) {
    std::string bytes;
    put(bytes, uint32_t(table.size()));
    bytes.append(table.begin(), table.end());
    put(bytes, p);
    bytes.append(paged.pages[p].begin(), paged.pages[p].end());
    if (!writeFile(dir / (in.stem().string() + "-page" + std::to_string(p) + ".pages"), bytes)) return 2;
  }
  return 0;
}

std::string fileBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// The bake's journal and the stream_resume input made of it and the files beside the output.
int streamJournal(const std::filesystem::path& journalDir, const std::filesystem::path& resumeDir) {
  std::filesystem::create_directories(journalDir);
  std::filesystem::create_directories(resumeDir);
  const io::ManyOptions many{.count = 3, .triangles = 400, .seed = 5};
  lod::MeshSource source;
  source.layout = io::generateManyLayout(many);
  source.mesh = [many](uint32_t i) -> Result<Mesh> { return io::generateManyMesh(many, i); };
  source.key = "gen:many:3x400:5";
  lod::BuildConfig config;
  config.threads = 1;
  for (bool paged : {false, true}) {
    const std::string name = paged ? "paged" : "flat";
    lod::LodWriteOptions write;
    write.paged = paged;
    write.pages.pageBytes = 4096;
    const std::string out = (fuzz::scratchDir() / (name + ".mrg")).string(), journalPath = bake::journalPath(out);
    auto journal = bake::Journal::open(journalPath, bake::streamFingerprint(source, config, write), many.count, 0);
    if (!journal) {
      std::fprintf(stderr, "%s\n", journal.error().message.c_str());
      return 2;
    }
    constexpr uint32_t killedAt = 2;
    lod::StreamJournal stream{{}, [&](uint32_t mesh, std::span<const uint8_t> record) -> Status {
                                if (mesh == killedAt) return Error{"killed"};
                                return journal->append(mesh, record);
                              }};
    Status baked = lod::bakeLodFile(source, out, config, write, {}, nullptr, {}, nullptr, nullptr, &stream);
    if (baked || baked.error().message != "killed") {
      std::fprintf(stderr, "the bake was not stopped at mesh %u\n", killedAt);
      return 2;
    }
    const std::string journalBytes = fileBytes(journalPath);
    if (!writeFile(journalDir / (name + ".journal"), journalBytes)) return 2;
    auto read = bake::readJournal(journalPath, bake::streamFingerprint(source, config, write), many.count);
    if (!read || read->entries.size() != killedAt) {
      std::fprintf(stderr, "the journal does not read back\n");
      return 2;
    }
    std::string resume; // fuzz_stream_resume's layout
    put(resume, many.count);
    put(resume, uint32_t(read->entries.size()));
    for (const bake::JournalEntry& e : read->entries) {
      put(resume, uint32_t(e.bytes.size()));
      resume.append(e.bytes.begin(), e.bytes.end());
    }
    for (const std::string& file : {lod::streamPartialPath(out), lod::streamSpoolPath(out)}) {
      const std::string bytes = fileBytes(file);
      put(resume, uint32_t(bytes.size()));
      resume += bytes;
    }
    if (!writeFile(resumeDir / (name + ".resume"), resume)) return 2;
    lod::removeStreamFiles(out);
  }
  return 0;
}

} // namespace

int main(int argc, char** argv) {
  if (argc == 4 && std::strcmp(argv[1], "chunks") == 0) return chunks(argv[2], argv[3]);
  if (argc == 4 && std::strcmp(argv[1], "scen") == 0) return scen(argv[2], argv[3]);
  if (argc == 3 && std::strcmp(argv[1], "meshopt-glb") == 0) return meshoptGlb(argv[2]);
  if (argc == 3 && std::strcmp(argv[1], "stream-messages") == 0) return streamMessages(argv[2]);
  if (argc == 4 && std::strcmp(argv[1], "pages") == 0) return pages(argv[2], argv[3]);
  if (argc == 4 && std::strcmp(argv[1], "stream-journal") == 0) return streamJournal(argv[2], argv[3]);
  std::fprintf(stderr, "usage: seed_tool chunks in.mrg out_dir | scen in out.SCEN | meshopt-glb out.glb | "
                       "stream-messages out_dir | pages in.mrg out_dir | stream-journal journal_dir resume_dir\n");
  return 2;
}
