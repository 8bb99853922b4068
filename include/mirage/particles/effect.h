#pragma once
// Particle effects (docs/particles.md): an effect file (TOML) holds one or more [[system]]s, each
// the seed's modules: common values, a shape, over-lifetime modules, colour over speed and a
// texture sheet. loadEffectFile reads and checks everything (keys, types, ranges, cross-field
// rules through validateSystem); errors are one line "<file>:<line>: <what>: <problem>" naming the
// key. CPU only; nothing here throws.
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "mirage/core/result.h"

namespace mirage::particles {

constexpr uint64_t kMaxEffectFileBytes = 1ull << 20;
constexpr uint32_t kMaxSystems = 64;
constexpr uint32_t kMaxParticlesPerSystem = 1u << 26; // 64 M: a Particle pool of 3.8 GB
// Longest prewarm (it runs duration / dt steps at creation: bounded so a file cannot stall a run).
constexpr float kMaxPrewarmSeconds = 60.0f;
constexpr uint32_t kMaxCurveKeys = 8;   // MIRAGE_PARTICLE_KEYS
constexpr uint32_t kMaxSheetTiles = 64; // per axis
constexpr float kMaxCoordinate = 1e6f;
constexpr float kMaxSeconds = 1e5f;

// A random value in [min, max] per particle (min == max: a constant).
struct Range {
  float min = 0.0f;
  float max = 0.0f;
};
struct Range3 {
  glm::vec3 min{0.0f};
  glm::vec3 max{0.0f};
};
struct ColorRange {
  glm::vec4 min{1.0f};
  glm::vec4 max{1.0f};
};

enum class ShapeType : uint8_t { Sphere, Hemisphere, Cone, Circle, Box, Edge };
enum class BoxEmit : uint8_t { Volume, Shell, Edge };

// Shape space: +Y is the emission direction of cone, box and edge; circle and arcs lie in XZ,
// the arc starting at +X towards +Z.
struct ShapeModule {
  ShapeType type = ShapeType::Cone;
  float radius = 1.0f;          // sphere, hemisphere, cone base, circle; edge: half length along X
  float radiusThickness = 1.0f; // 0: emit from the shell (surface / rim) only, 1: the whole volume
  float arcDegrees = 360.0f;
  float angleDegrees = 25.0f; // cone: between +Y and the side
  glm::vec3 boxSize{1.0f};
  BoxEmit boxEmit = BoxEmit::Volume;
  glm::vec3 position{0.0f}; // offsets of the shape in the system's frame
  glm::vec3 rotationDegrees{0.0f};
  glm::vec3 scale{1.0f};
  float randomizeDirection = 0.0f; // 0..1
  float randomizePosition = 0.0f;  // world units
};

// A piecewise linear curve over normalized age; no keys: constant 1.
struct Curve {
  std::vector<glm::vec2> keys; // (t, value), t ascending in [0, 1]
};
struct Gradient {
  std::vector<float> times; // ascending in [0, 1]
  std::vector<glm::vec4> colors;
};

struct TextureSheet {
  std::string texture = "none"; // a generated sheet (generateSheet): none, puff, spark, flame, drop
  uint32_t tilesX = 1, tilesY = 1;
  bool singleRow = false; // animate along one row (else the whole sheet)
  uint32_t row = 0;
  bool randomRow = false;
  float cycles = 1.0f;             // animation cycles over a lifetime
  Range startFrame;                // frames
  bool alphaFromGreyscale = false; // the renderer takes alpha from the sheet's luminance
};

struct SystemDef {
  std::string name;
  uint32_t line = 0; // of its [[system]] header
  // Common values.
  glm::vec3 position{0.0f};
  glm::vec3 rotationDegrees{0.0f}; // XYZ Euler angles of the emitter
  float duration = 5.0f;           // seconds of one emission cycle
  bool looping = true;
  bool prewarm = false;    // start as if one whole cycle had run (looping only)
  float startDelay = 0.0f; // seconds before the first emission
  Range startLifetime{5.0f, 5.0f};
  Range startSpeed{5.0f, 5.0f};
  Range startSize{1.0f, 1.0f};
  Range startRotationDegrees;
  ColorRange startColor;
  float gravityModifier = 0.0f; // times (0, -9.81, 0)
  uint32_t maxParticles = 1000;
  float rateOverTime = 10.0f; // particles per second
  uint32_t seed = 1;
  TextureSheet sheet;
  ShapeModule shape;
  // Over-lifetime modules (absent: no effect).
  Range3 velocityOverLifetime;
  Range3 forceOverLifetime;
  Range angularVelocityDegrees; // rotation over lifetime, degrees / s
  Curve sizeOverLifetime;
  Gradient colorOverLifetime;
  Gradient colorOverSpeed;
  Range colorOverSpeedRange{0.0f, 1.0f};
};

struct EffectFile {
  std::string name; // the path as given
  std::vector<SystemDef> systems;
};

Result<EffectFile> loadEffectFile(const std::filesystem::path& path);
// The same from text; `name` stands for the file in errors.
Result<EffectFile> parseEffectFile(std::string_view text, const std::string& name);

// Cross-field rules of a system built in code or parsed: ranges ordered, curve keys ascending,
// prewarm only when looping, without a start delay and
// for at most kMaxPrewarmSeconds, rows within the sheet. Error: one line
// "<key>: <problem>" (the parser prefixes file, line and system).
Status validateSystem(const SystemDef& system);

} // namespace mirage::particles
