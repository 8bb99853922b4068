// The 'TMAP' chunk (source triangle -> level-0 cluster) of a cluster-LOD asset: the input replaces
// the TMAP of a small valid asset, whose SCEN and CDAG chunks it is checked against on load.
#include "fuzz_support.h"

using namespace mirage;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<fuzz::Chunk> chunks = fuzz::lodAssetChunks();
  for (fuzz::Chunk& c : chunks)
    if (c.type == asset::chunk::SourceMap) c.bytes.assign(data, data + size);
  fuzz::loadEveryWay(fuzz::writeMrg("in.mrg", chunks));
  return 0;
}
