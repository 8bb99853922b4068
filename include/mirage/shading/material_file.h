#pragma once
// Material files (docs/shading.md): a TOML file that defines materials ([[material]]), assigns them
// to the meshes or materials of any imported scene by name or glob ([[assign]]) and adds point
// lights ([[light]]). loadMaterialFile reads and checks everything (keys, types, ranges, textures
// found and decoded) so that applyMaterials cannot fail on the file itself. Errors are one line
// "<file>:<line>: <what>: <problem>" naming the key. CPU only; nothing here throws.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "mirage/core/image.h"
#include "mirage/core/result.h"
#include "mirage/core/scene.h"

namespace mirage::shading {

// Largest material file read (a text file of definitions, not data).
constexpr uint64_t kMaxMaterialFileBytes = 4ull << 20;

// A texture a material file names, decoded once however many materials use it.
struct FileTexture {
  std::filesystem::path path; // resolved relative to the material file
  ImageRGBA8 image;
};

// One [[material]]: `material` holds factors, model, alpha mode and UV transforms (its texture
// indices are -1); `textures` index MaterialFile::textures per MaterialMap, -1 for none.
struct MaterialDef {
  Material material;
  int32_t textures[kMaterialMapCount] = {-1, -1, -1, -1, -1, -1, -1, -1};
  uint32_t line = 0; // of its [[material]] header
};

// One [[assign]]: meshes whose name, or meshes whose imported material's name, matches `pattern`
// (exact, or a glob with * and ?) get material `material` (index into MaterialFile::materials).
struct Assignment {
  enum class Target : uint8_t { Mesh, Material };
  Target target = Target::Mesh;
  std::string pattern;
  uint32_t material = 0;
  uint32_t line = 0;
};

struct MaterialFile {
  std::string name; // the path as given (what errors and origins print)
  std::vector<MaterialDef> materials;
  std::vector<Assignment> assignments; // in file order: a later matching one wins
  std::vector<PointLight> lights;
  std::vector<FileTexture> textures;
};

Result<MaterialFile> loadMaterialFile(const std::filesystem::path& path);
// The same from text; `name` stands for the file in errors, `baseDir` resolves texture paths.
Result<MaterialFile> parseMaterialFile(std::string_view text, const std::string& name,
                                       const std::filesystem::path& baseDir);

// `*` matches any run of characters (also none), `?` any one character, everything else itself.
bool globMatch(std::string_view pattern, std::string_view text);

// Applies the file to an imported scene: each mesh gets the material of the last assignment that
// matches it (by its name or its material's name); the file's materials used are appended to
// scene.materials with their textures (albedo sRGB, every other map linear) and Material::origin
// "<file>:<line>"; the lights are appended to scene.lights. Materials no mesh uses any more stay.
// Error: an assignment that matches no mesh ("<file>:<line>: assign: ... matches no mesh"), so a
// typo is not silently ignored; the scene is then unchanged.
Status applyMaterials(Scene& scene, const MaterialFile& file);

} // namespace mirage::shading
