// What a resumable streaming bake checks before it continues (lod::checkStreamResume): the mesh
// records its journal holds and the partial output and spool beside the output. Input: u32 mesh
// count, u32 record count, per record u32 size and the bytes, then u32 size and the bytes of the
// partial output and of the spool (size 0xffffffff: the file is missing). What is accepted must be
// one decoded record per record, each chunk inside its mesh's bytes after the previous mesh's, the
// spool growing, both files holding every mesh's bytes, statistics that decode; the files are left
// as they were. Rejections are one line.
#include <algorithm>
#include <cstring>
#include <fstream>
#include <optional>

#include <nlohmann/json.hpp>

#include "fuzz_support.h"
#include "mirage/asset/container.h"
#include "mirage/lod/stream_bake.h"

using namespace mirage;

namespace {

constexpr uint32_t kAbsent = 0xffffffffu;

struct Input {
  std::span<const uint8_t> rest;
  bool take(void* out, size_t n) {
    if (rest.size() < n) return false;
    std::memcpy(out, rest.data(), n);
    rest = rest.subspan(n);
    return true;
  }
  // A u32 size and that many bytes (kAbsent: none, and `absent` set); nullopt when too few are left.
  std::optional<std::span<const uint8_t>> section(bool& absent) {
    uint32_t n = 0;
    absent = false;
    if (!take(&n, 4)) return std::nullopt;
    if (n == kAbsent) {
      absent = true;
      return std::span<const uint8_t>();
    }
    if (rest.size() < n) return std::nullopt;
    std::span<const uint8_t> s = rest.first(n);
    rest = rest.subspan(n);
    return s;
  }
};

std::vector<uint8_t> fileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Input in{std::span(data, size)};
  uint32_t meshCount = 0, recordCount = 0;
  // A bake's mesh count fits a file (bakeLodFile refuses more); records come from its journal.
  if (!in.take(&meshCount, 4) || !in.take(&recordCount, 4) || meshCount > asset::kMaxChunks - 3 || recordCount > 4096)
    return 0;
  std::vector<std::vector<uint8_t>> records;
  bool absent = false;
  for (uint32_t i = 0; i < recordCount; ++i) {
    auto r = in.section(absent);
    if (!r || absent) return 0;
    records.emplace_back(r->begin(), r->end());
  }
  const std::string out = (fuzz::scratchDir() / "out.mrg").string();
  const std::string partialPath = lod::streamPartialPath(out), spoolPath = lod::streamSpoolPath(out);
  std::optional<std::vector<uint8_t>> files[2];
  for (int f = 0; f < 2; ++f) {
    const std::string& path = f == 0 ? partialPath : spoolPath;
    auto s = in.section(absent);
    if (!s) return 0;
    std::filesystem::remove(path);
    if (absent) continue;
    fuzz::writeScratch(std::filesystem::path(path).filename().string(), *s);
    files[f].emplace(s->begin(), s->end());
  }

  auto resume = lod::checkStreamResume(out, meshCount, records);
  for (int f = 0; f < 2; ++f) {
    const std::string& path = f == 0 ? partialPath : spoolPath;
    fuzz::check(files[f] ? fileBytes(path) == *files[f] : !std::filesystem::exists(path),
                "checkStreamResume changed a file");
  }
  if (!resume) {
    fuzz::checkOneLine(resume.error());
    return 0;
  }
  fuzz::check(resume->meshes.size() == records.size(), "not one mesh per record");
  if (records.empty()) return 0;
  fuzz::check(files[0] && files[1], "resumed with a file missing");
  uint64_t fileEnd = asset::AssetStreamWriter::payloadStart(meshCount + 3), spoolEnd = 0;
  for (const lod::StreamMeshRecord& m : resume->meshes) {
    fuzz::check(m.chunk.offset >= fileEnd && m.chunk.offset <= m.file.end &&
                    m.file.end - m.chunk.offset == m.chunk.storedBytes,
                "a mesh's chunk lies outside its bytes");
    fuzz::check(m.spool.end >= spoolEnd, "the spool shrinks");
    fuzz::check(!nlohmann::json::from_cbor(m.stats, true, false).is_discarded(), "statistics do not decode");
    fileEnd = m.file.end, spoolEnd = m.spool.end;
  }
  fuzz::check(fileEnd <= files[0]->size() && spoolEnd <= files[1]->size(), "a mesh's bytes lie past a file's end");
  return 0;
}
