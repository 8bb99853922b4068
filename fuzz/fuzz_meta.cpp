// The 'META' JSON chunk: the input replaces the META of a small valid cluster-LOD asset, and of a
// plain scene file (whose loader checks META's counts against the SCEN chunk).
#include "fuzz_support.h"

using namespace mirage;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::vector<fuzz::Chunk> chunks = fuzz::lodAssetChunks();
  for (fuzz::Chunk& c : chunks)
    if (c.type == asset::chunk::Meta) c.bytes.assign(data, data + size);
  fuzz::loadEveryWay(fuzz::writeMrg("lod.mrg", chunks));

  std::vector<fuzz::Chunk> scene;
  for (const fuzz::Chunk& c : chunks)
    if (c.type == asset::chunk::Scene || c.type == asset::chunk::Meta) scene.push_back(c);
  fuzz::loadEveryWay(fuzz::writeMrg("scene.mrg", scene));
  return 0;
}
