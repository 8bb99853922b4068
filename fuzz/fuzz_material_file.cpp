// Material files (`--materials mats.toml`): any text is accepted or rejected with one line; an
// accepted file applies to a small scene without failing on the file itself.
#include "fuzz_support.h"
#include "mirage/shading/material_file.h"

using namespace mirage;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string text(reinterpret_cast<const char*>(data), size);
  // Textures resolve in a folder that does not exist: texture keys exercise the error path.
  Result<shading::MaterialFile> file = shading::parseMaterialFile(text, "mats.toml", "/nonexistent-fuzz-dir");
  if (!file) {
    fuzz::checkOneLine(file.error());
    return 0;
  }
  Scene scene;
  scene.source = "fuzz.gltf";
  scene.meshes.resize(2);
  scene.meshes[0].name = "wall_a";
  scene.meshes[1].name = "floor";
  scene.materials.resize(1);
  scene.materials[0].name = "brick";
  Status applied = shading::applyMaterials(scene, *file);
  if (!applied) {
    fuzz::checkOneLine(applied.error());
    return 0;
  }
  for (const Mesh& m : scene.meshes) fuzz::check(m.material < scene.materials.size(), "mesh material out of range");
  return 0;
}
