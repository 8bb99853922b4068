// glTF 2.0: binary .glb when the input starts with the GLB magic, else .gltf JSON (buffers and
// images then come from data: URIs). Reaches EXT_meshopt_compression, KHR_mesh_quantization and
// the image decoders.
#include <cstring>

#include "fuzz_support.h"
#include "mirage/io/import.h"

using namespace mirage;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  bool binary = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
  std::filesystem::path path = fuzz::writeScratch(binary ? "in.glb" : "in.gltf", std::span(data, size));
  Result<Scene> scene = io::importGltf(path);
  if (scene)
    fuzz::checkImportedScene(*scene, path);
  else
    fuzz::checkOneLine(scene.error());
  return 0;
}
