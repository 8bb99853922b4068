#include "codec.h"

#include <algorithm>
#include <cstdio>
#include <thread>

#include <xxhash.h>
#include <zstd.h>

namespace mirage::asset::detail {

std::string hex(uint64_t v) {
  char buf[24];
  std::snprintf(buf, sizeof(buf), "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

uint64_t hash64(std::span<const uint8_t> bytes) { return XXH3_64bits(bytes.data(), bytes.size()); }

Result<std::vector<uint8_t>> compressFrame(std::span<const uint8_t> data, int level) {
  ZSTD_CCtx* cctx = ZSTD_createCCtx();
  if (!cctx) return Error{"zstd: cannot create a compression context"};
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_compressionLevel, level);
  // The frame must declare its content size: the reader checks it against the table.
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_contentSizeFlag, 1);
  if (data.size() >= (8u << 20)) {
    int workers = int(std::min(8u, std::max(1u, std::thread::hardware_concurrency())));
    ZSTD_CCtx_setParameter(cctx, ZSTD_c_nbWorkers, workers); // ignored error: library built without threads
  }
  std::vector<uint8_t> out(ZSTD_compressBound(data.size()));
  size_t n = ZSTD_compress2(cctx, out.data(), out.size(), data.data(), data.size());
  ZSTD_freeCCtx(cctx);
  if (ZSTD_isError(n)) return Error{std::string("zstd: ") + ZSTD_getErrorName(n)};
  out.resize(n);
  return out;
}

std::string decompressFrame(std::span<const uint8_t> stored, uint64_t rawBytes, std::vector<uint8_t>& out) {
  // Ask the frame before allocating: its declared size must be exactly the table's.
  unsigned long long frameSize = ZSTD_getFrameContentSize(stored.data(), stored.size());
  if (frameSize == ZSTD_CONTENTSIZE_ERROR || frameSize == ZSTD_CONTENTSIZE_UNKNOWN || frameSize != rawBytes)
    return "zstd frame size does not match the table (" + std::to_string(rawBytes) + " bytes)";
  size_t frameBytes = ZSTD_findFrameCompressedSize(stored.data(), stored.size());
  if (ZSTD_isError(frameBytes) || frameBytes != stored.size()) return "payload is not exactly one zstd frame";
  out.resize(rawBytes);
  size_t n = ZSTD_decompress(out.data(), out.size(), stored.data(), stored.size());
  if (ZSTD_isError(n)) return std::string("zstd: ") + ZSTD_getErrorName(n);
  if (n != rawBytes) return "decompressed to " + std::to_string(n) + " bytes, expected " + std::to_string(rawBytes);
  return {};
}

} // namespace mirage::asset::detail
