// Effect files: the shipped examples parse, every key lands in its field, and every error path
// names the file, the line and the key in one line.
#include <fstream>

#include <gtest/gtest.h>

#include "mirage/particles/effect.h"
#include "test_support.h"

using namespace mirage;
using namespace mirage::particles;

namespace {

std::string errorOf(const std::string& text) {
  auto r = parseEffectFile(text, "fx.toml");
  EXPECT_FALSE(r.ok()) << "expected an error for:\n" << text;
  if (r.ok()) return "";
  EXPECT_EQ(r.error().message.find('\n'), std::string::npos) << r.error().message;
  return r.error().message;
}

TEST(EffectFile, ExamplesParse) {
  for (const char* name : {"smoke", "fire", "sparks", "rain"}) {
    auto path = std::filesystem::path(MIRAGE_SOURCE_DIR) / "examples/particles" / (std::string(name) + ".toml");
    auto fx = loadEffectFile(path);
    ASSERT_TRUE(fx.ok()) << fx.error().message;
    EXPECT_FALSE(fx->systems.empty()) << name;
    for (const SystemDef& s : fx->systems) EXPECT_TRUE(validateSystem(s).ok()) << name << " " << s.name;
  }
}

TEST(EffectFile, EveryKeyReachesItsField) {
  auto fx = parseEffectFile(R"(
[[system]]
name = "a"
position = [1, 2, 3]
rotation = [0, 90, 0]
duration = 2.5
looping = false
start_delay = 0.5
start_lifetime = [1, 2]
start_speed = 3
start_size = [0.1, 0.2]
start_rotation = [10, 20]
start_color = [[0, 0, 0, 0], [1, 1, 1, 1]]
gravity_modifier = 0.5
max_particles = 123
rate_over_time = 45
seed = 9
texture = "puff"
tiles = [4, 2]
alpha_from_greyscale = true
[system.shape]
type = "box"
size = [1, 2, 3]
emit_from = "edge"
position = [0, 1, 0]
rotation = [0, 0, 45]
scale = [2, 2, 2]
randomize_direction = 0.25
randomize_position = 0.1
[system.velocity_over_lifetime]
velocity = [[0, 1, 0], [0, 2, 0]]
[system.force_over_lifetime]
force = [1, 0, 0]
[system.size_over_lifetime]
curve = [[0, 1], [1, 0]]
[system.rotation_over_lifetime]
angular_velocity = [-90, 90]
[system.color_over_lifetime]
gradient = [[0, 1, 0, 0, 1], [1, 0, 0, 1, 0]]
[system.color_over_speed]
range = [1, 4]
gradient = [[0, 1, 1, 1, 1]]
[system.texture_sheet]
mode = "single_row"
row = 1
cycles = 2
start_frame = [0, 3]
)",
                            "fx.toml");
  ASSERT_TRUE(fx.ok()) << fx.error().message;
  const SystemDef& s = fx->systems.at(0);
  EXPECT_EQ(s.name, "a");
  EXPECT_EQ(s.position, glm::vec3(1, 2, 3));
  EXPECT_EQ(s.rotationDegrees.y, 90.0f);
  EXPECT_EQ(s.duration, 2.5f);
  EXPECT_FALSE(s.looping);
  EXPECT_EQ(s.startDelay, 0.5f);
  EXPECT_EQ(s.startLifetime.min, 1.0f);
  EXPECT_EQ(s.startLifetime.max, 2.0f);
  EXPECT_EQ(s.startSpeed.min, 3.0f);
  EXPECT_EQ(s.startSpeed.max, 3.0f);
  EXPECT_EQ(s.startRotationDegrees.max, 20.0f);
  EXPECT_EQ(s.startColor.max, glm::vec4(1.0f));
  EXPECT_EQ(s.gravityModifier, 0.5f);
  EXPECT_EQ(s.maxParticles, 123u);
  EXPECT_EQ(s.rateOverTime, 45.0f);
  EXPECT_EQ(s.seed, 9u);
  EXPECT_EQ(s.sheet.texture, "puff");
  EXPECT_EQ(s.sheet.tilesX, 4u);
  EXPECT_EQ(s.sheet.tilesY, 2u);
  EXPECT_TRUE(s.sheet.alphaFromGreyscale);
  EXPECT_EQ(s.shape.type, ShapeType::Box);
  EXPECT_EQ(s.shape.boxEmit, BoxEmit::Edge);
  EXPECT_EQ(s.shape.boxSize, glm::vec3(1, 2, 3));
  EXPECT_EQ(s.shape.position.y, 1.0f);
  EXPECT_EQ(s.shape.rotationDegrees.z, 45.0f);
  EXPECT_EQ(s.shape.scale.x, 2.0f);
  EXPECT_EQ(s.shape.randomizeDirection, 0.25f);
  EXPECT_EQ(s.shape.randomizePosition, 0.1f);
  EXPECT_EQ(s.velocityOverLifetime.max.y, 2.0f);
  EXPECT_EQ(s.forceOverLifetime.min, s.forceOverLifetime.max);
  EXPECT_EQ(s.sizeOverLifetime.keys.size(), 2u);
  EXPECT_EQ(s.angularVelocityDegrees.min, -90.0f);
  EXPECT_EQ(s.colorOverLifetime.colors.at(1), glm::vec4(0, 0, 1, 0));
  EXPECT_EQ(s.colorOverSpeedRange.max, 4.0f);
  EXPECT_TRUE(s.sheet.singleRow);
  EXPECT_EQ(s.sheet.row, 1u);
  EXPECT_EQ(s.sheet.cycles, 2.0f);
  EXPECT_EQ(s.sheet.startFrame.max, 3.0f);
}

TEST(EffectFile, ErrorsNameFileLineAndKey) {
  EXPECT_EQ(errorOf("[[system]]\nname = \"a\"\nspeed = 1\n"), "fx.toml:3: system \"a\": unknown key \"speed\"");
  EXPECT_EQ(errorOf("[[system]]\n[system.wind]\nx = 1\n"), "fx.toml:2: system 1: unknown key \"wind\"");
  EXPECT_EQ(errorOf("[[system]]\n[system.shape]\ntype = \"cone\"\nangel = 3\n"),
            "fx.toml:4: system 1 shape: unknown key \"angel\"");
  EXPECT_EQ(errorOf("[[system]]\nmax_particles = -5\n"),
            "fx.toml:2: system 1: \"max_particles\" = -5 is outside 1..67108864");
  EXPECT_EQ(errorOf("[[system]]\nmax_particles = 1.5\n"), "fx.toml:2: system 1: \"max_particles\" must be an integer");
  EXPECT_EQ(errorOf("[[system]]\nrate_over_time = -1\n"),
            "fx.toml:2: system 1: \"rate_over_time\" = -1 is outside 0..1000000000");
  EXPECT_EQ(errorOf("[[system]]\nlooping = 1\n"), "fx.toml:2: system 1: \"looping\" must be true or false");
  EXPECT_EQ(errorOf("[[system]]\nduration = \"long\"\n"), "fx.toml:2: system 1: \"duration\" must be a number");
  EXPECT_EQ(errorOf("[[system]]\n[system.shape]\ntype = \"torus\"\n"),
            "fx.toml:3: system 1 shape: \"type\" = \"torus\": expected \"sphere\", \"hemisphere\", \"cone\", "
            "\"circle\", \"box\" or \"edge\"");
  EXPECT_NE(errorOf("[[system]]\nstart_lifetime = [3, 1]\n").find("fx.toml:1: system 1: \"start_lifetime\": min 3"),
            std::string::npos);
  EXPECT_NE(errorOf("[[system]]\nlooping = false\nprewarm = true\n").find("\"prewarm\" needs looping"),
            std::string::npos);
  EXPECT_NE(errorOf("[[system]]\nprewarm = true\nduration = 1000\n").find("\"prewarm\" of a 1000 s duration"),
            std::string::npos);
  EXPECT_NE(errorOf("[[system]]\n[system.size_over_lifetime]\ncurve = [[0.5, 1], [0.2, 1]]\n").find("ascend"),
            std::string::npos);
  EXPECT_NE(errorOf("[[system]]\n[system.size_over_lifetime]\ncurve = [[1.5, 1]]\n").find("fx.toml:3:"),
            std::string::npos);
  EXPECT_NE(errorOf("[[system]]\ntexture = \"lava\"\n").find("\"texture\" = \"lava\""), std::string::npos);
  EXPECT_NE(
      errorOf("[[system]]\nname = \"a\"\n[[system]]\nname = \"a\"\n").find("fx.toml:3: system \"a\": defined twice"),
      std::string::npos);
  EXPECT_NE(errorOf("").find("no [[system]]"), std::string::npos);
  EXPECT_NE(errorOf("[[system]\n").find("fx.toml:1:"), std::string::npos);
  EXPECT_NE(errorOf("[[system]]\nstart_color = [1, 1, 1]\n").find("\"start_color\" must be an array of 4"),
            std::string::npos);
  EXPECT_NE(errorOf("[[system]]\ntiles = [4, 0]\n").find("\"tiles\"[1] = 0"), std::string::npos);
  EXPECT_NE(errorOf("[[system]]\n[system.texture_sheet]\nrow = 1\n").find("single_row"), std::string::npos);
}

TEST(EffectFile, MissingFileIsOneLine) {
  auto r = loadEffectFile("/nonexistent/fx.toml");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, "/nonexistent/fx.toml: file not found");
}

} // namespace
