#pragma once
// The .mrg asset container: a header, a chunk table and 16-byte-aligned chunk payloads, each
// payload zstd-compressed (or stored raw when that is not smaller) and checked with XXH3-64 before
// and after decompression, or blocked (blocks.h: an index, then independently compressed and
// checked blocks that a reader reads one at a time). Byte layout, versioning policy and the reason
// for every check: docs/asset.md; on-disk structs: format.h.
//
// Reserved chunk types (a file may hold several chunks of one type; readers skip unknown types):
//   'SCEN' scene: meshes, materials, embedded RGBA8 textures, instances (scene_chunk.h)
//   'MESH' mesh geometry
//   'CDAG' cluster DAG (opaque bytes written by the LOD module)
//   'CPAG' paged cluster DAG (blocked; page table in the index, one block per page: LOD module)
//   'SURF' surfels
//   'PVS ' potentially visible sets
//   'META' JSON metadata (format version, counts; for tools and humans)
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "mirage/asset/blocks.h"
#include "mirage/asset/file_marks.h"
#include "mirage/asset/format.h"
#include "mirage/asset/source.h"
#include "mirage/core/result.h"
#include "mirage/core/temp_files.h"

namespace mirage::asset {

struct FourCC {
  uint32_t code = 0;
  constexpr FourCC() = default;
  constexpr explicit FourCC(uint32_t c) : code(c) {}
  // FourCC("SCEN"): four characters, stored first character in the low byte.
  constexpr FourCC(const char (&s)[5])
      : code(uint32_t(uint8_t(s[0])) | uint32_t(uint8_t(s[1])) << 8 | uint32_t(uint8_t(s[2])) << 16 |
             uint32_t(uint8_t(s[3])) << 24) {}
  // Printable form for messages; non-printable bytes appear as \xNN.
  std::string str() const;
  friend constexpr bool operator==(FourCC, FourCC) = default;
};

namespace chunk {
inline constexpr FourCC Scene{"SCEN"};
inline constexpr FourCC Mesh{"MESH"};
inline constexpr FourCC ClusterDag{"CDAG"};
inline constexpr FourCC ClusterPages{"CPAG"}; // paged cluster DAG, blocked: block p = page p
inline constexpr FourCC SourceMap{"TMAP"};    // cluster-LOD asset: source triangle -> level-0 cluster
inline constexpr FourCC Surfels{"SURF"};
inline constexpr FourCC Visibility{"PVS "};
inline constexpr FourCC Meta{"META"};
} // namespace chunk

// zstd level 3 compresses scene data at a few hundred MB/s; bakers that write once and load often
// can pass up to 19 (22 needs more decoder memory). 0 stores the chunk raw.
inline constexpr int kDefaultZstdLevel = 3;

// One chunk-table entry, as validated by AssetReader::open.
struct ChunkInfo {
  FourCC type;
  bool compressed = false; // zstd frame on disk
  bool blocked = false;    // block index + blocks (blocks.h); storedHash covers the index only
  uint64_t offset = 0;
  uint64_t storedBytes = 0;
  uint64_t rawBytes = 0;
  uint64_t storedHash = 0;
  uint64_t rawHash = 0;
  int32_t zstdLevel = 0;
  uint64_t indexBytes = 0; // blocked: the index at the payload's start
};

// A chunk compressed as AssetWriter::addChunk stores it, made without a writer (so on several
// threads at once) and handed to addStoredChunk: the file gets the bytes addChunk would give.
struct StoredChunk {
  ChunkInfo info;
  std::vector<uint8_t> stored;
};
Result<StoredChunk> storeChunk(FourCC type, std::span<const uint8_t> data, int zstdLevel = kDefaultZstdLevel);

// Collects chunks, then writes them in one atomic step. Chunks are compressed when added, so the
// writer holds only the compressed bytes.
class AssetWriter {
public:
  // zstdLevel: 0 stores raw, otherwise a zstd level (clamped to zstd's range). Compressed output
  // that is not smaller than the input is stored raw instead. Compression errors surface in write().
  void addChunk(FourCC type, std::span<const uint8_t> data, int zstdLevel = kDefaultZstdLevel);
  // A chunk exactly as another file stores it (from AssetReader::readStoredChunk): its bytes, level
  // and checksums are kept, so copying a chunk between files never recompresses it.
  void addStoredChunk(const ChunkInfo& info, std::vector<uint8_t> stored);
  // A blocked payload (encodeBlocks / assembleBlocks), stored as is; its chunk checksum covers the
  // index. `zstdLevel` is the level its blocks were compressed with (informational). A payload
  // whose index does not decode is an error reported by write(). Makes the file version 2.
  void addBlockedChunk(FourCC type, std::vector<uint8_t> payload, int zstdLevel = kDefaultZstdLevel);
  size_t chunkCount() const { return chunks_.size(); }

  // Writes "<path>.tmp-<pid>", fsyncs it and renames it over `path`, so readers see either the
  // old file or the complete new one. On any failure the temp file is removed and `path` is
  // untouched. Writes nothing but these two names (a symlink at `path` is replaced, not followed).
  // `check`, when given, reads the complete temp file back (its argument is the temp path) before
  // the rename: a writer that must not publish a file its readers reject fails there instead.
  Status write(const std::string& path, const std::function<Status(const std::string& tempPath)>& check = {}) const;

private:
  struct Pending {
    ChunkInfo info;
    std::vector<uint8_t> stored;
  };
  std::vector<Pending> chunks_;
  std::optional<Error> error_; // first addChunk failure, reported by write()
};

// Writes chunks to the file as they are added, for outputs larger than memory: the layout of
// AssetWriter (header, table, payloads at aligned offsets in the order added) with the table
// reserved for up to `maxChunks` entries and written, with the header, by finish(); the same temp
// file, fsync, optional read-back check and rename, so a failed or abandoned write (the destructor)
// leaves nothing at `path`. Holds one chunk's bytes at a time (addChunkFromFile: none).
//
// Resumable (createResumable, resume): the temp file has a fixed name that a later process finds,
// and neither a signal nor the destructor removes it (its owner does, with the record of its
// checkpoints); checkpoint() makes the bytes so far durable and marks them, and resume() continues
// the file after its last mark, so a bake killed mid-way loses only what followed that mark.
class AssetStreamWriter {
public:
  static Result<AssetStreamWriter> create(const std::string& path, uint32_t maxChunks);
  // A new resumable write whose temp file is `partial` (replaced if there).
  static Result<AssetStreamWriter> createResumable(const std::string& path, const std::string& partial,
                                                   uint32_t maxChunks);
  // Continues the resumable write in `partial` at `end`, the end of its last checkpoint (whose bytes
  // the caller checked: matchingFileMarks), with `table` the entries of the chunks added before it.
  // What follows `end` (a chunk cut short, or the last chunks and table of a write killed in
  // finish) is cut off; the bytes before it stay as they are.
  static Result<AssetStreamWriter> resume(const std::string& path, const std::string& partial, uint32_t maxChunks,
                                          std::span<const ChunkEntry> table, uint64_t end);
  // Where the first payload goes: the header and the table reserved for maxChunks entries come
  // first (written by finish), so checkpoints cover the bytes from here on.
  static uint64_t payloadStart(uint32_t maxChunks);
  AssetStreamWriter(AssetStreamWriter&& other) noexcept;
  AssetStreamWriter& operator=(AssetStreamWriter&& other) noexcept;
  AssetStreamWriter(const AssetStreamWriter&) = delete;
  AssetStreamWriter& operator=(const AssetStreamWriter&) = delete;
  ~AssetStreamWriter(); // removes the temp file unless finish() published it

  // As AssetWriter's adds; errors name the output. After an error every call fails.
  Status addChunk(FourCC type, std::span<const uint8_t> data, int zstdLevel = kDefaultZstdLevel);
  Status addStoredChunk(const StoredChunk& chunk);
  Status addBlockedChunk(FourCC type, std::span<const uint8_t> payload, int zstdLevel = kDefaultZstdLevel);
  // A chunk whose raw bytes are the whole file `rawPath` (spooled while other chunks were written),
  // compressed as one zstd frame a piece at a time (raw when that is not smaller).
  Status addChunkFromFile(FourCC type, const std::string& rawPath, int zstdLevel = kDefaultZstdLevel);
  uint64_t bytesWritten() const { return at_; }
  size_t chunkCount() const { return table_.size(); }
  std::span<const ChunkEntry> table() const { return table_; } // the entries of the chunks added
  // fdatasync, then the mark of the bytes written since the previous checkpoint (the first: since
  // payloadStart). The caller records it (and the table) only now that the bytes are durable.
  Result<FileMark> checkpoint();
  // Table and header, fsync, `check` on the temp file (as AssetWriter::write), rename.
  Status finish(const std::function<Status(const std::string& tempPath)>& check = {});

private:
  AssetStreamWriter() = default;
  Status append(const ChunkInfo& info, std::span<const uint8_t> stored);
  Status padTo(uint64_t offset);
  Status failed(const std::string& problem);
  static Result<AssetStreamWriter> open(const std::string& path, const std::string& temp, bool resumable,
                                        uint32_t maxChunks);
  std::string path_, tmp_;
  TempFileGuard tmpGuard_; // tmp_ goes if a signal stops the process before finish() (unless resumable)
  int fd_ = -1;
  bool resumable_ = false; // tmp_ is kept when the writer is dropped
  uint32_t maxChunks_ = 0;
  uint64_t at_ = 0;
  uint64_t marked_ = 0; // end of the last checkpoint
  std::vector<ChunkEntry> table_;
  bool anyBlocked_ = false;
  std::optional<Error> error_;
};

// Reads a validated .mrg file. open() checks the whole structure (magic, version, header and table
// checksums, bounds, overlaps, sizes) so that readChunk only has payload checks left. Reads use
// pread on an open descriptor: readChunk is const and safe to call from several threads.
class AssetReader {
public:
  // A file path or an http:// / https:// URL (asset/source.h: read by byte ranges).
  static Result<AssetReader> open(const std::string& path, const SourceOptions& options = {});

  AssetReader(AssetReader&& other) noexcept;
  AssetReader& operator=(AssetReader&& other) noexcept;
  AssetReader(const AssetReader&) = delete;
  AssetReader& operator=(const AssetReader&) = delete;
  ~AssetReader();

  const std::string& path() const { return path_; }
  // Requests made and bytes received from the file or server since open.
  SourceStats sourceStats() const;
  uint64_t fileBytes() const { return fileBytes_; }
  uint32_t version() const { return version_; } // of this file: kMinFormatVersion..kFormatVersion
  const std::vector<ChunkInfo>& chunks() const { return chunks_; }
  // Index of the first chunk of `type`, if any.
  std::optional<size_t> find(FourCC type) const;

  // The decompressed payload, after checking the stored hash, the zstd frame's declared size, the
  // decompressed size and the raw hash.
  Result<std::vector<uint8_t>> readChunk(size_t index) const;
  // The first chunk of `type`; an error naming the type when there is none.
  Result<std::vector<uint8_t>> readChunk(FourCC type) const;
  // The payload as stored (compressed or not), after checking its stored hash: what
  // AssetWriter::addStoredChunk copies into another file unchanged. For a blocked chunk, also what
  // readChunk returns: the index checked against the chunk checksum and every block against its
  // stored checksum (decodeBlocks decompresses them and checks their raw checksums).
  Result<std::vector<uint8_t>> readStoredChunk(size_t index) const;

  // Blocked chunks, read piecewise: the index (one read of indexBytes, checked against the chunk
  // checksum, decoded), then any block by its byte range (checked and decompressed). Errors name the
  // file, the chunk and the block.
  Result<BlockTable> readBlockTable(size_t index) const;
  Result<std::vector<uint8_t>> readBlock(size_t index, const BlockTable& table, size_t block) const;
  // "<file>: chunk <index> <type>": the context of errors about one chunk.
  std::string chunkContext(size_t index) const;

private:
  AssetReader() = default;
  Error error(const std::string& problem) const { return makeError(path_, problem); }

  std::string path_;
  std::unique_ptr<ByteSource> source_;
  uint64_t fileBytes_ = 0;
  uint32_t version_ = kFormatVersion;
  std::vector<ChunkInfo> chunks_;
};

} // namespace mirage::asset
