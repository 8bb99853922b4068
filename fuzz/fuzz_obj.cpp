// Wavefront OBJ with its MTL library and a texture. The input is the OBJ text, optionally followed
// by a line "#mtl" and the text of "m.mtl"; "t.png" (a 2x2 PNG) sits beside them, so seeds that say
// `mtllib m.mtl` and `map_Kd t.png` reach material and texture loading.
#include <cstring>

#include "fuzz_support.h"
#include "mirage/io/image_io.h"
#include "mirage/io/import.h"

using namespace mirage;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const bool texture = [] {
    ImageRGBA8 image;
    image.width = image.height = 2;
    image.pixels = {255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255, 255, 255, 128};
    return bool(io::writePng(fuzz::scratchDir() / "t.png", image));
  }();
  fuzz::check(texture, "cannot write t.png");

  std::string_view text(reinterpret_cast<const char*>(data), size);
  static constexpr std::string_view kSplit = "\n#mtl\n";
  size_t split = text.find(kSplit);
  std::string_view obj = text.substr(0, split);
  std::string_view mtl = split == std::string_view::npos ? std::string_view() : text.substr(split + kSplit.size());
  std::filesystem::remove(fuzz::scratchDir() / "m.mtl");
  if (split != std::string_view::npos) fuzz::writeScratch("m.mtl", mtl);
  std::filesystem::path path = fuzz::writeScratch("in.obj", obj);

  Result<Scene> scene = io::importObj(path);
  if (scene)
    fuzz::checkImportedScene(*scene, path);
  else
    fuzz::checkOneLine(scene.error());
  return 0;
}
