// Whole .mrg files through every loader. An input starting with the .mrg magic is used as the file
// itself (header, chunk table, checksums, zstd frames); any other input is a list of chunks, each
// a FourCC, a little-endian uint32 size and that many bytes, written into a valid container so the
// fuzzer's bytes get past the checksums and reach every chunk decoder, in any combination.
#include <cstring>

#include "fuzz_support.h"
#include "mirage/asset/format.h"

using namespace mirage;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size >= sizeof(asset::kMagic) && std::memcmp(data, asset::kMagic, sizeof(asset::kMagic)) == 0) {
    fuzz::loadEveryWay(fuzz::writeScratch("in.mrg", std::span(data, size)));
    return 0;
  }
  std::vector<fuzz::Chunk> chunks;
  size_t at = 0;
  while (at + 8 <= size && chunks.size() < 64) {
    uint32_t type = 0, bytes = 0;
    std::memcpy(&type, data + at, 4);
    std::memcpy(&bytes, data + at + 4, 4);
    at += 8;
    size_t n = std::min<size_t>(bytes, size - at);
    chunks.push_back({asset::FourCC(type), std::vector<uint8_t>(data + at, data + at + n)});
    at += n;
  }
  fuzz::loadEveryWay(fuzz::writeMrg("in.mrg", chunks));
  return 0;
}
