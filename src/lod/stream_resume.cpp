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

Result<StreamMeshRecord> decodeStreamRecord(std::span<const uint8_t> bytes, const std::string& where) {
  asset::ByteReader r(bytes, where);
  StreamMeshRecord m;
  r.read(m.chunk);
  r.read(m.file.end), r.read(m.file.hash), r.read(m.spool.end), r.read(m.spool.hash);
  r.read(m.bounds.min), r.read(m.bounds.max);
  r.read(m.triangles), r.read(m.clusters), r.read(m.pages);
  r.readArray(m.stats);
  if (Status s = r.finish(); !s) return s.error();
  if (nlohmann::json::from_cbor(m.stats, true, false).is_discarded())
    return makeError(where, "mesh statistics do not decode");
  return m;
}

} // namespace

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
    std::string where = path + ": the journal's record of mesh " + std::to_string(i);
    auto m = decodeStreamRecord(records[i], where);
    if (!m) return makeError(path, "damaged bake journal (" + m.error().message + "): remove it and bake again");
    // Each chunk lies after the previous mesh's and ends this mesh's bytes; the spool grows.
    if (m->chunk.offset < fileEnd || m->chunk.offset + m->chunk.storedBytes != m->file.end || m->spool.end < spoolEnd)
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
