// A resumable streaming bake's records: each mesh's chunk entry, where the partial output and the
// spool end after it (with the hashes of their bytes since the previous mesh), and what the scene
// and META chunks need of it; checked against both files before a bake continues.
#include "stream_resume.h"

#include <cstdio>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "mirage/asset/bytes.h"
#include "mirage/asset/container.h"

namespace mirage::lod {

namespace {

// nlohmann's DOM builder with the limits of decodeStats (its CBOR reader recurses once per level
// and stops when a callback returns false).
class LimitedSax {
public:
  LimitedSax(nlohmann::json& out, size_t bytes) : dom_(out, false), bytes_(bytes) {}
  bool null() { return dom_.null(); }
  bool boolean(bool v) { return dom_.boolean(v); }
  bool number_integer(nlohmann::json::number_integer_t v) { return dom_.number_integer(v); }
  bool number_unsigned(nlohmann::json::number_unsigned_t v) { return dom_.number_unsigned(v); }
  bool number_float(nlohmann::json::number_float_t v, const std::string& s) { return dom_.number_float(v, s); }
  bool string(nlohmann::json::string_t& v) { return dom_.string(v); }
  bool binary(nlohmann::json::binary_t& v) { return dom_.binary(v); }
  bool key(nlohmann::json::string_t& v) { return dom_.key(v); }
  // Each element takes a byte at least; size_t(-1): indefinite length.
  bool start_object(size_t n) { return enter(n) && dom_.start_object(n); }
  bool start_array(size_t n) { return enter(n) && dom_.start_array(n); }
  bool end_object() { return --depth_, dom_.end_object(); }
  bool end_array() { return --depth_, dom_.end_array(); }
  bool parse_error(size_t at, const std::string& token, const nlohmann::detail::exception& e) {
    return dom_.parse_error(at, token, e);
  }

private:
  bool enter(size_t n) { return ++depth_ <= kMaxStatsDepth && (n == size_t(-1) || n <= bytes_); }
  nlohmann::detail::json_sax_dom_parser<nlohmann::json> dom_;
  size_t bytes_;
  uint32_t depth_ = 0;
};

Result<StreamMeshRecord> decodeStreamRecord(std::span<const uint8_t> bytes, const std::string& where) {
  asset::ByteReader r(bytes, where);
  StreamMeshRecord m;
  r.read(m.chunk);
  r.read(m.file.end), r.read(m.file.hash), r.read(m.spool.end), r.read(m.spool.hash);
  r.read(m.bounds.min), r.read(m.bounds.max);
  r.read(m.triangles), r.read(m.clusters), r.read(m.pages);
  r.readArray(m.stats);
  if (Status s = r.finish(); !s) return s.error();
  if (decodeStats(m.stats).is_discarded()) return makeError(where, "mesh statistics do not decode");
  return m;
}

} // namespace

nlohmann::json decodeStats(std::span<const uint8_t> cbor) {
  nlohmann::json out;
  LimitedSax sax(out, cbor.size());
  if (!nlohmann::json::sax_parse(cbor, &sax, nlohmann::json::input_format_t::cbor, /*strict=*/true))
    return nlohmann::json(nlohmann::json::value_t::discarded);
  return out;
}

std::vector<uint8_t> encodeStreamRecord(const StreamMeshRecord& m) {
  asset::ByteWriter w;
  w.write(m.chunk);
  w.write(m.file.end), w.write(m.file.hash), w.write(m.spool.end), w.write(m.spool.hash);
  w.write(m.bounds.min), w.write(m.bounds.max);
  w.write(m.triangles), w.write(m.clusters), w.write(m.pages);
  w.writeArray(std::span<const uint8_t>(m.stats));
  return w.take();
}

void removeStreamFiles(const std::string& path) {
  std::remove(streamPartialPath(path).c_str());
  std::remove(streamSpoolPath(path).c_str());
}

Result<StreamResume> checkStreamResume(const std::string& path, uint32_t meshCount,
                                       std::span<const std::vector<uint8_t>> records) {
  StreamResume out;
  if (records.empty()) return out;
  const std::string partial = streamPartialPath(path), spool = streamSpoolPath(path);
  const std::string again = ": remove it and its journal, or bake without --resume";
  if (records.size() > meshCount)
    return makeError(path, "the journal records " + std::to_string(records.size()) + " meshes of " +
                               std::to_string(meshCount));
  std::vector<asset::FileMark> fileMarks, spoolMarks;
  uint64_t fileEnd = asset::AssetStreamWriter::payloadStart(streamChunkCount(meshCount)), spoolEnd = 0;
  for (size_t i = 0; i < records.size(); ++i) {
    std::string where = "the journal's record of mesh " + std::to_string(i); // the message names path once
    auto m = decodeStreamRecord(records[i], where);
    if (!m) return makeError(path, "damaged bake journal (" + m.error().message + "): remove it and bake again");
    // Each chunk lies after the previous mesh's and ends this mesh's bytes (compared without
    // overflow: a damaged offset and size must not wrap to the end); the spool grows.
    if (m->chunk.offset < fileEnd || m->chunk.offset > m->file.end ||
        m->file.end - m->chunk.offset != m->chunk.storedBytes || m->spool.end < spoolEnd)
      return makeError(path, "damaged bake journal (" + where +
                                 " does not follow the one before): remove it and "
                                 "bake again");
    fileEnd = m->file.end, spoolEnd = m->spool.end;
    fileMarks.push_back(m->file), spoolMarks.push_back(m->spool);
    out.meshes.push_back(std::move(m).value());
  }
  for (const auto& [file, marks, begin] :
       {std::tuple{partial, &fileMarks, asset::AssetStreamWriter::payloadStart(streamChunkCount(meshCount))},
        std::tuple{spool, &spoolMarks, uint64_t(0)}}) {
    if (!std::filesystem::exists(file))
      return makeError(file, "missing (the journal records " + std::to_string(records.size()) +
                                 " meshes written there): remove the journal, or bake without --resume");
    auto matching = asset::matchingFileMarks(file, begin, *marks);
    if (!matching) return matching.error();
    if (*matching < marks->size())
      return makeError(file,
                       "mesh " + std::to_string(*matching) + "'s bytes differ from the journal (damaged)" + again);
  }
  return out;
}

} // namespace mirage::lod
