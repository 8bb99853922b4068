// The 'SCEN' chunk payload: decodeScene must reject whatever validateScene rejects, and what it
// accepts must encode back to a payload that decodes to the same bytes.
#include "fuzz_support.h"
#include "mirage/asset/scene_chunk.h"

using namespace mirage;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Result<Scene> scene = asset::decodeScene(std::span(data, size), "in.mrg");
  if (!scene) {
    fuzz::checkOneLine(scene.error());
    return 0;
  }
  fuzz::checkImportedScene(*scene, "in.mrg");
  return 0;
}
