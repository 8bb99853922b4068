// Material files: every key parsed into the right field, every error path naming file, line and
// key, glob matching, and assignment precedence (the last matching [[assign]] wins).
#include <fstream>

#include <gtest/gtest.h>

#include "mirage/io/image_io.h"
#include "mirage/shading/material_file.h"
#include "test_scenes.h"
#include "test_support.h"

using namespace mirage;
using namespace mirage::shading;

namespace {

// A directory holding a 2x2 PNG "red.png" beside the material files the tests write.
std::filesystem::path textureDir() {
  static std::filesystem::path dir = [] {
    auto d = test::tempDir("material_file");
    ImageRGBA8 img{2, 2, std::vector<uint8_t>(16, 255)};
    for (size_t i = 0; i < 16; i += 4) img.pixels[i + 1] = img.pixels[i + 2] = 0;
    EXPECT_TRUE(io::writePng(d / "red.png", img).ok());
    std::ofstream(d / "broken.png") << "not a png";
    return d;
  }();
  return dir;
}

Result<MaterialFile> parse(const std::string& text) { return parseMaterialFile(text, "mats.toml", textureDir()); }

std::string errorOf(const std::string& text) {
  auto r = parse(text);
  EXPECT_FALSE(r.ok()) << "expected an error for:\n" << text;
  return r.ok() ? "" : r.error().message;
}

// A scene of three quads named "floor", "wall_a", "wall_b" with imported materials "stone", "brick", "brick".
Scene threeMeshes() {
  std::vector<Mesh> meshes = {test::makeQuad(1, 0, 0), test::makeQuad(1, 1, 1), test::makeQuad(1, 2, 1)};
  meshes[0].name = "floor", meshes[1].name = "wall_a", meshes[2].name = "wall_b";
  Scene s = test::makeScene(meshes, {test::solidMaterial({1, 1, 1, 1}), test::solidMaterial({1, 0, 0, 1})});
  s.materials[0].name = "stone", s.materials[1].name = "brick";
  s.source = "three.gltf";
  return s;
}

} // namespace

TEST(MaterialFile, ParsesEveryKey) {
  auto r = parse(R"(
[[material]]
name = "steel"
model = "metallic-roughness"
albedo = [0.5, 0.25, 0.125]
albedo_texture = "red.png"
albedo_uv_scale = [2, 3]
albedo_uv_offset = [0.5, 0.25]
normal_texture = "red.png"
normal_strength = 0.5
metallic = 1
roughness = 0.3
emissive = [1, 2, 3]
alpha_mode = "MASK"
alpha_cutoff = 0.25
double_sided = true
uv_scale = [4, 4]

[[material]]
name = "plastic"
model = "blinn-phong"
albedo = [1, 1, 1, 0.5]
glossiness = 0.75
specular = [0.2, 0.3, 0.4]
alpha_mode = "BLEND"
detail_albedo_texture = "red.png"
detail_mask_texture = "red.png"
detail_mask_uv_scale = [8, 8]

[[assign]]
mesh = "wall_*"
use = "steel"

[[light]]
position = [1, 2, 3]
color = [1, 0.5, 0.25]
intensity = 4
radius = 7.5
)");
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(r->materials.size(), 2u);
  const Material& steel = r->materials[0].material;
  EXPECT_EQ(steel.name, "steel");
  EXPECT_EQ(steel.origin, "mats.toml:2");
  EXPECT_EQ(steel.model, ShadingModel::MetallicRoughness);
  EXPECT_EQ(steel.baseColorFactor, glm::vec4(0.5f, 0.25f, 0.125f, 1.0f));
  EXPECT_EQ(steel.uv[kMapBaseColor].scale, glm::vec2(2, 3));
  EXPECT_EQ(steel.uv[kMapBaseColor].offset, glm::vec2(0.5f, 0.25f));
  EXPECT_EQ(steel.uv[kMapNormal].scale, glm::vec2(4, 4)); // uv_scale for the maps not given their own
  EXPECT_FLOAT_EQ(steel.normalScale, 0.5f);
  EXPECT_FLOAT_EQ(steel.metallicFactor, 1.0f);
  EXPECT_FLOAT_EQ(steel.roughnessFactor, 0.3f);
  EXPECT_EQ(steel.emissiveFactor, glm::vec3(1, 2, 3));
  EXPECT_EQ(steel.alphaMode, AlphaMode::Mask);
  EXPECT_FLOAT_EQ(steel.alphaCutoff, 0.25f);
  EXPECT_TRUE(steel.doubleSided);
  EXPECT_EQ(r->materials[0].textures[kMapBaseColor], 0);
  EXPECT_EQ(r->materials[0].textures[kMapNormal], 0); // one decode per file
  const Material& plastic = r->materials[1].material;
  EXPECT_EQ(plastic.model, ShadingModel::BlinnPhong);
  EXPECT_FLOAT_EQ(plastic.baseColorFactor.a, 0.5f);
  EXPECT_FLOAT_EQ(plastic.glossiness, 0.75f);
  EXPECT_EQ(plastic.specularColor, glm::vec3(0.2f, 0.3f, 0.4f));
  EXPECT_EQ(plastic.alphaMode, AlphaMode::Blend);
  EXPECT_EQ(plastic.uv[kMapDetailMask].scale, glm::vec2(8, 8));
  EXPECT_EQ(r->materials[1].textures[kMapDetailAlbedo], 0);
  ASSERT_EQ(r->textures.size(), 1u);
  EXPECT_EQ(r->textures[0].image.width, 2u);
  ASSERT_EQ(r->assignments.size(), 1u);
  EXPECT_EQ(r->assignments[0].pattern, "wall_*");
  EXPECT_EQ(r->assignments[0].line, 30u);
  ASSERT_EQ(r->lights.size(), 1u);
  EXPECT_EQ(r->lights[0].position, glm::vec3(1, 2, 3));
  EXPECT_EQ(r->lights[0].color, glm::vec3(1, 0.5f, 0.25f));
  EXPECT_FLOAT_EQ(r->lights[0].intensity, 4.0f);
  EXPECT_FLOAT_EQ(r->lights[0].radius, 7.5f);
}

TEST(MaterialFile, ErrorsNameFileLineAndKey) {
  struct Case {
    const char* text;
    const char* message;
  };
  const Case cases[] = {
      {"[[material]]\nname = \"steel\"\nroughnes = 0.5\n", "mats.toml:3: material \"steel\": unknown key \"roughnes\""},
      {"[[material]]\nname = \"a\"\nroughness = 1.5\n",
       "mats.toml:3: material \"a\": \"roughness\" = 1.5 is outside 0..1"},
      {"[[material]]\nname = \"a\"\nmetallic = \"x\"\n", "mats.toml:3: material \"a\": \"metallic\" must be a number"},
      {"[[material]]\nname = \"a\"\nalbedo = [1, 2]\n",
       "mats.toml:3: material \"a\": \"albedo\" must be an array of 3 or 4 numbers"},
      {"[[material]]\nname = \"a\"\nalbedo = [1, 0.5, -1]\n",
       "mats.toml:3: material \"a\": \"albedo\"[2] = -1 is outside 0..1"},
      {"[[material]]\nname = \"a\"\nmodel = \"phong\"\n",
       "mats.toml:3: material \"a\": \"model\" = \"phong\": expected \"metallic-roughness\" or \"blinn-phong\""},
      {"[[material]]\nname = \"a\"\nalpha_mode = \"mask\"\n",
       "mats.toml:3: material \"a\": \"alpha_mode\" = \"mask\": expected \"OPAQUE\", \"MASK\" or \"BLEND\""},
      {"[[material]]\nname = \"a\"\nalpha_cutoff = 0.5\n",
       "mats.toml:3: material \"a\": \"alpha_cutoff\" needs alpha_mode = \"MASK\""},
      {"[[material]]\nname = \"a\"\nmodel = \"blinn-phong\"\nroughness = 0.5\n",
       "mats.toml:4: material \"a\": \"roughness\" does not apply to model \"blinn-phong\""},
      {"[[material]]\nname = \"a\"\nglossiness = 0.5\n",
       "mats.toml:3: material \"a\": \"glossiness\" does not apply to model \"metallic-roughness\""},
      {"[[material]]\nname = \"a\"\nalbedo_texture = \"missing.png\"\n",
       "mats.toml:3: material \"a\": \"albedo_texture\": "},
      {"[[material]]\nname = \"a\"\nnormal_texture = \"broken.png\"\n",
       "mats.toml:3: material \"a\": \"normal_texture\": "},
      {"[[material]]\nname = \"a\"\ndetail_mask_texture = \"red.png\"\n",
       "mats.toml:3: material \"a\": \"detail_mask_texture\" needs detail_albedo_texture or detail_normal_texture"},
      {"[[material]]\nalbedo = [1, 1, 1]\n", "mats.toml:1: material: missing key \"name\""},
      {"[[material]]\nname = \"a\"\n[[material]]\nname = \"a\"\n",
       "mats.toml:3: material \"a\": defined twice (first at line 1)"},
      {"[[material]]\nname = \"a\"\ndouble_sided = 1\n",
       "mats.toml:3: material \"a\": \"double_sided\" must be true or false"},
      {"[[material]]\nname = \"a\"\nuv_scale = [1, 1e9]\n",
       "mats.toml:3: material \"a\": \"uv_scale\"[1] = 1000000000 is outside -10000..10000"},
      {"[[assign]]\nmesh = \"x\"\nuse = \"nothing\"\n",
       "mats.toml:3: assign: \"use\" = \"nothing\": no [[material]] of that name"},
      {"[[material]]\nname = \"a\"\n[[assign]]\nmesh = \"x\"\nmaterial = \"y\"\nuse = \"a\"\n",
       "mats.toml:3: assign: needs exactly one of \"mesh\" and \"material\""},
      {"[[material]]\nname = \"a\"\n[[assign]]\nmesh = \"x\"\n", "mats.toml:3: assign: missing key \"use\""},
      {"[[material]]\nname = \"a\"\n[[assign]]\nmesh = \"x\"\nuse = \"a\"\nwith = 1\n",
       "mats.toml:6: assign: unknown key \"with\""},
      {"[[light]]\ncolor = [1, 1, 1]\n", "mats.toml:1: light 1: missing key \"position\""},
      {"[[light]]\nposition = [0, 0, 0]\nradius = 0\n",
       "mats.toml:3: light 1: \"radius\" = 0 is outside 0.001..10000000"},
      {"[[light]]\nposition = [0, 0, 0]\n[[light]]\nposition = [0, 0, 0]\nbrightness = 2\n",
       "mats.toml:5: light 2: unknown key \"brightness\""},
      {"materials = 1\n", "mats.toml:1: top level: unknown key \"materials\""},
      {"material = 1\n", "mats.toml:1: top level: \"material\" must be an array of tables ([[material]])"},
      {"[[material]]\nname = \"a\"\nalbedo = [1, 1,\n", "mats.toml:3: "}, // TOML syntax, from toml++
  };
  for (const Case& c : cases) {
    std::string message = errorOf(c.text);
    EXPECT_EQ(message.rfind(c.message, 0), 0u) << "got:      " << message << "\nexpected: " << c.message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
}

TEST(MaterialFile, LoadNamesThePathGiven) {
  auto dir = textureDir();
  std::ofstream(dir / "bad.toml") << "[[material]]\nname = \"steel\"\nroughnes = 0.5\n";
  auto r = loadMaterialFile(dir / "bad.toml");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, (dir / "bad.toml").string() + ":3: material \"steel\": unknown key \"roughnes\"");
  auto missing = loadMaterialFile(dir / "none.toml");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().message, (dir / "none.toml").string() + ": file not found");
  // Textures resolve relative to the material file, not the working directory.
  std::filesystem::create_directories(dir / "sub");
  std::ofstream(dir / "sub" / "ok.toml") << "[[material]]\nname = \"a\"\nalbedo_texture = \"../red.png\"\n";
  auto ok = loadMaterialFile(dir / "sub" / "ok.toml");
  ASSERT_TRUE(ok.ok()) << ok.error().message;
  EXPECT_EQ(ok->textures[0].path, (dir / "red.png").lexically_normal());
}

TEST(MaterialFile, GlobMatch) {
  EXPECT_TRUE(globMatch("wall", "wall"));
  EXPECT_FALSE(globMatch("wall", "walls"));
  EXPECT_TRUE(globMatch("wall*", "wall"));
  EXPECT_TRUE(globMatch("wall*", "wall_a"));
  EXPECT_TRUE(globMatch("*_a", "wall_a"));
  EXPECT_FALSE(globMatch("*_a", "wall_b"));
  EXPECT_TRUE(globMatch("w?ll_?", "wall_b"));
  EXPECT_FALSE(globMatch("w?ll_?", "wall_bb"));
  EXPECT_TRUE(globMatch("*", ""));
  EXPECT_TRUE(globMatch("a*b*c", "aXXbYYbc"));
  EXPECT_FALSE(globMatch("a*b*c", "aXXbYYbd"));
  EXPECT_FALSE(globMatch("?", ""));
}

TEST(MaterialFile, LaterAssignmentWins) {
  // Documented precedence (docs/shading.md): assignments apply in file order, a later match
  // replaces an earlier one whether either is exact or a glob.
  auto r = parse(R"(
[[material]]
name = "red"
albedo = [1, 0, 0]
[[material]]
name = "green"
albedo = [0, 1, 0]
[[material]]
name = "blue"
albedo = [0, 0, 1]
[[assign]]
mesh = "wall_a"
use = "red"
[[assign]]
mesh = "*"
use = "green"
[[assign]]
material = "br?ck"
use = "blue"
)");
  ASSERT_TRUE(r.ok()) << r.error().message;
  Scene s = threeMeshes();
  ASSERT_TRUE(applyMaterials(s, *r).ok());
  auto nameOf = [&](size_t mesh) { return s.materials[s.meshes[mesh].material].name; };
  EXPECT_EQ(nameOf(0), "green"); // floor: only "*"
  EXPECT_EQ(nameOf(1), "blue");  // wall_a: exact "red", then "*", then its material "brick": the last wins
  EXPECT_EQ(nameOf(2), "blue");
  EXPECT_EQ(s.materials[s.meshes[1].material].origin, "mats.toml:8");
  EXPECT_EQ(s.materials.size(), 4u); // the two imported + green + blue (red ended up unused: not added)

  // Reversed order: the exact name written last wins over the glob.
  auto reversed = parse(R"(
[[material]]
name = "red"
[[material]]
name = "green"
[[assign]]
mesh = "*"
use = "green"
[[assign]]
mesh = "wall_a"
use = "red"
)");
  ASSERT_TRUE(reversed.ok());
  Scene s2 = threeMeshes();
  ASSERT_TRUE(applyMaterials(s2, *reversed).ok());
  EXPECT_EQ(s2.materials[s2.meshes[1].material].name, "red");
  EXPECT_EQ(s2.materials[s2.meshes[2].material].name, "green");
}

TEST(MaterialFile, ApplyAddsTexturesAndLights) {
  auto r = parse(R"(
[[material]]
name = "tex"
albedo_texture = "red.png"
normal_texture = "red.png"
[[assign]]
mesh = "floor"
use = "tex"
[[light]]
position = [0, 1, 0]
)");
  ASSERT_TRUE(r.ok()) << r.error().message;
  Scene s = threeMeshes();
  ASSERT_TRUE(applyMaterials(s, *r).ok());
  const Material& m = s.materials[s.meshes[0].material];
  ASSERT_EQ(s.textures.size(), 2u); // one file, two colour spaces
  EXPECT_TRUE(s.textures[size_t(m.baseColorTexture)].srgb);
  EXPECT_FALSE(s.textures[size_t(m.normalTexture)].srgb);
  EXPECT_EQ(s.textures[size_t(m.baseColorTexture)].rgba8.size(), 16u);
  ASSERT_EQ(s.lights.size(), 1u);
  EXPECT_EQ(s.lights[0].position, glm::vec3(0, 1, 0));
  EXPECT_EQ(s.meshes[1].material, 1u); // unassigned meshes keep their material
}

TEST(MaterialFile, AssignmentMatchingNothingIsAnErrorAndChangesNothing) {
  auto r = parse("[[material]]\nname = \"a\"\n[[assign]]\nmesh = \"floor\"\nuse = \"a\"\n[[assign]]\nmesh = "
                 "\"flor\"\nuse = \"a\"\n");
  ASSERT_TRUE(r.ok()) << r.error().message;
  Scene s = threeMeshes();
  Status st = applyMaterials(s, *r);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().message, "mats.toml:6: assign: mesh \"flor\" matches no mesh name of three.gltf");
  EXPECT_EQ(s.materials.size(), 2u);
  EXPECT_EQ(s.meshes[0].material, 0u);
}
