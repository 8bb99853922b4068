// The rules of a system beyond single keys (validateSystem), its flattening into the shared
// parameters, and the emission schedule both simulations follow.
#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <glm/gtc/matrix_transform.hpp>

#include "mirage/particles/simulation.h"

namespace mirage::particles {

namespace {

Status ordered(const char* key, float lo, float hi) {
  if (lo > hi) return Error{fmt::format("\"{}\": min {} is above max {}", key, lo, hi)};
  return Ok{};
}

Status ascending(const char* key, std::span<const float> times) {
  for (size_t i = 1; i < times.size(); ++i)
    if (times[i] < times[i - 1])
      return Error{fmt::format("\"{}\": key times must ascend ({} after {})", key, times[i], times[i - 1])};
  return Ok{};
}

#define MIRAGE_TRY(expr)                                                                                               \
  do {                                                                                                                 \
    if (auto status_ = (expr); !status_) return status_.error();                                                       \
  } while (0)

// XYZ Euler angles in degrees: rotate about X, then Y, then Z (R = Rz * Ry * Rx).
glm::mat3 eulerDegrees(glm::vec3 degrees) {
  glm::vec3 r = glm::radians(degrees);
  glm::mat4 m = glm::rotate(glm::mat4(1.0f), r.z, glm::vec3(0, 0, 1));
  m = glm::rotate(m, r.y, glm::vec3(0, 1, 0));
  return glm::mat3(glm::rotate(m, r.x, glm::vec3(1, 0, 0)));
}

} // namespace

Status validateSystem(const SystemDef& s) {
  MIRAGE_TRY(ordered("start_lifetime", s.startLifetime.min, s.startLifetime.max));
  if (s.startLifetime.min <= 0.0f) return Error{"\"start_lifetime\" must be above 0"};
  if (!(s.duration > 0.0f)) return Error{"\"duration\" must be above 0"};
  MIRAGE_TRY(ordered("start_speed", s.startSpeed.min, s.startSpeed.max));
  MIRAGE_TRY(ordered("start_size", s.startSize.min, s.startSize.max));
  MIRAGE_TRY(ordered("start_rotation", s.startRotationDegrees.min, s.startRotationDegrees.max));
  MIRAGE_TRY(ordered("angular_velocity", s.angularVelocityDegrees.min, s.angularVelocityDegrees.max));
  MIRAGE_TRY(ordered("start_frame", s.sheet.startFrame.min, s.sheet.startFrame.max));
  for (int a = 0; a < 3; ++a) {
    MIRAGE_TRY(ordered("velocity", s.velocityOverLifetime.min[a], s.velocityOverLifetime.max[a]));
    MIRAGE_TRY(ordered("force", s.forceOverLifetime.min[a], s.forceOverLifetime.max[a]));
  }
  if (s.maxParticles == 0 || s.maxParticles > kMaxParticlesPerSystem)
    return Error{fmt::format("\"max_particles\" = {} is outside 1..{}", s.maxParticles, kMaxParticlesPerSystem)};
  if (!(s.rateOverTime >= 0.0f)) return Error{"\"rate_over_time\" must not be negative"};
  if (s.prewarm && !s.looping) return Error{"\"prewarm\" needs looping = true"};
  if (s.prewarm && s.startDelay > 0.0f) return Error{"\"prewarm\" and \"start_delay\" exclude each other"};
  if (s.prewarm && s.duration > kMaxPrewarmSeconds)
    return Error{fmt::format("\"prewarm\" of a {} s duration: at most {} s", s.duration, kMaxPrewarmSeconds)};
  if (s.sizeOverLifetime.keys.size() > kMaxCurveKeys || s.colorOverLifetime.times.size() > kMaxCurveKeys ||
      s.colorOverSpeed.times.size() > kMaxCurveKeys)
    return Error{fmt::format("a curve or gradient has more than {} keys", kMaxCurveKeys)};
  std::vector<float> times;
  for (glm::vec2 k : s.sizeOverLifetime.keys) times.push_back(k.x);
  MIRAGE_TRY(ascending("curve", times));
  MIRAGE_TRY(ascending("gradient", s.colorOverLifetime.times));
  MIRAGE_TRY(ascending("gradient", s.colorOverSpeed.times));
  if (s.colorOverLifetime.times.size() != s.colorOverLifetime.colors.size() ||
      s.colorOverSpeed.times.size() != s.colorOverSpeed.colors.size())
    return Error{"\"gradient\": times and colours differ in count"};
  if (!(s.colorOverSpeedRange.min < s.colorOverSpeedRange.max) && !s.colorOverSpeed.times.empty())
    return Error{"\"range\": the lower speed must be below the upper"};
  const TextureSheet& t = s.sheet;
  if (t.tilesX < 1 || t.tilesY < 1 || t.tilesX > kMaxSheetTiles || t.tilesY > kMaxSheetTiles)
    return Error{fmt::format("\"tiles\" must be 1..{} each", kMaxSheetTiles)};
  if (t.singleRow && t.row >= t.tilesY)
    return Error{fmt::format("\"row\" = {}: the sheet has {} rows", t.row, t.tilesY)};
  if (!t.singleRow && (t.randomRow || t.row != 0))
    return Error{"\"row\" and \"random_row\" need mode = \"single_row\""};
  static constexpr const char* kTextures[] = {"none", "puff", "spark", "flame", "drop"};
  if (std::find_if(std::begin(kTextures), std::end(kTextures), [&](const char* n) { return t.texture == n; }) ==
      std::end(kTextures))
    return Error{fmt::format("\"texture\" = \"{}\": expected none, puff, spark, flame or drop", t.texture)};
  if (!(s.shape.radiusThickness >= 0.0f && s.shape.radiusThickness <= 1.0f))
    return Error{"\"radius_thickness\" must be in 0..1"};
  if (!(s.shape.randomizeDirection >= 0.0f && s.shape.randomizeDirection <= 1.0f))
    return Error{"\"randomize_direction\" must be in 0..1"};
  return Ok{};
}

shaderio::ParticleParams flattenSystem(const SystemDef& s) {
  shaderio::ParticleParams p{};
  const ShapeModule& sh = s.shape;
  glm::mat3 emitter = eulerDegrees(s.rotationDegrees);
  glm::mat3 shapeRotation = eulerDegrees(sh.rotationDegrees);
  p.directionToWorld = emitter * shapeRotation;
  p.shapeToWorld = p.directionToWorld * glm::mat3(glm::scale(glm::mat4(1.0f), sh.scale));
  p.origin = s.position + emitter * sh.position;
  p.shape = uint32_t(sh.type);
  p.radius = sh.radius;
  p.radiusThickness = sh.radiusThickness;
  p.arc = glm::radians(sh.arcDegrees);
  p.coneAngle = glm::radians(sh.angleDegrees);
  p.boxSize = sh.boxSize;
  p.boxMode = uint32_t(sh.boxEmit);
  p.randomizeDirection = sh.randomizeDirection;
  p.randomizePosition = sh.randomizePosition;
  p.lifetime = {s.startLifetime.min, s.startLifetime.max};
  p.speed = {s.startSpeed.min, s.startSpeed.max};
  p.size = {s.startSize.min, s.startSize.max};
  p.rotation = glm::radians(glm::vec2(s.startRotationDegrees.min, s.startRotationDegrees.max));
  p.colorMin = s.startColor.min;
  p.colorMax = s.startColor.max;
  p.gravity = glm::vec3(0.0f, -kGravity * s.gravityModifier, 0.0f);
  p.velocityMin = s.velocityOverLifetime.min;
  p.velocityMax = s.velocityOverLifetime.max;
  p.forceMin = s.forceOverLifetime.min;
  p.forceMax = s.forceOverLifetime.max;
  p.angularVelocity = glm::radians(glm::vec2(s.angularVelocityDegrees.min, s.angularVelocityDegrees.max));
  p.sizeKeyCount = uint32_t(std::min<size_t>(s.sizeOverLifetime.keys.size(), kMaxCurveKeys));
  for (uint32_t i = 0; i < p.sizeKeyCount; ++i) p.sizeKeys[i] = s.sizeOverLifetime.keys[i];
  p.colorKeyCount = uint32_t(std::min<size_t>(s.colorOverLifetime.times.size(), kMaxCurveKeys));
  for (uint32_t i = 0; i < p.colorKeyCount; ++i) {
    p.colorTimes[i] = s.colorOverLifetime.times[i];
    p.colorKeys[i] = s.colorOverLifetime.colors[i];
  }
  p.speedKeyCount = uint32_t(std::min<size_t>(s.colorOverSpeed.times.size(), kMaxCurveKeys));
  p.speedRange = {s.colorOverSpeedRange.min, s.colorOverSpeedRange.max};
  for (uint32_t i = 0; i < p.speedKeyCount; ++i) {
    p.speedTimes[i] = s.colorOverSpeed.times[i];
    p.speedColors[i] = s.colorOverSpeed.colors[i];
  }
  p.tiles = {s.sheet.tilesX, s.sheet.tilesY};
  p.sheetMode = s.sheet.singleRow ? MIRAGE_SHEET_ROW : MIRAGE_SHEET_WHOLE;
  p.sheetRow = s.sheet.row;
  p.randomRow = s.sheet.randomRow ? 1u : 0u;
  p.sheetCycles = s.sheet.cycles;
  p.startFrame = {s.sheet.startFrame.min, s.sheet.startFrame.max};
  p.seed = s.seed;
  return p;
}

uint64_t emittedBy(const SystemDef& s, double t) {
  double e = t - double(s.startDelay);
  if (e <= 0.0) return 0;
  double duration = double(s.duration), rate = double(s.rateOverTime);
  auto perCycle = uint64_t(std::floor(rate * duration));
  if (!s.looping) return e >= duration ? perCycle : uint64_t(std::floor(rate * e));
  double cycles = std::floor(e / duration);
  return uint64_t(cycles) * perCycle + uint64_t(std::floor(rate * (e - cycles * duration)));
}

uint32_t emitRequest(const SystemDef& s, uint64_t step, float dt) {
  // Times in double from the step count: no drift over long runs.
  double t0 = double(step) * double(dt), t1 = double(step + 1) * double(dt);
  uint64_t n = emittedBy(s, t1) - emittedBy(s, t0);
  return uint32_t(std::min<uint64_t>(n, s.maxParticles));
}

uint64_t prewarmSteps(const SystemDef& s, float dt) {
  return s.prewarm ? uint64_t(std::ceil(double(s.duration) / double(dt))) : 0;
}

EffectFile scaleEffect(const EffectFile& effect, uint64_t count) {
  EffectFile out = effect;
  uint64_t total = 0;
  for (const SystemDef& s : effect.systems) total += s.maxParticles;
  uint64_t given = 0;
  for (size_t i = 0; i < out.systems.size(); ++i) {
    SystemDef& s = out.systems[i];
    // The last system takes what is left (none left when the others already got their minimum of 1).
    uint64_t share = i + 1 == out.systems.size() ? (count > given ? count - given : 1)
                                                 : count * s.maxParticles / std::max<uint64_t>(total, 1);
    share = std::clamp<uint64_t>(share, 1, kMaxParticlesPerSystem);
    given += share;
    s.maxParticles = uint32_t(share);
    s.looping = true;
    s.prewarm = false;
    s.startDelay = 0.0f;
    // Four times the rate that keeps `share` alive at the shortest lifetime: the pool fills within a
    // quarter lifetime and stays full (with twice, overlapping waves of deaths left gaps, measured).
    s.rateOverTime = float(4.0 * double(share) / double(s.startLifetime.min));
  }
  return out;
}

uint64_t fillSteps(const EffectFile& effect, float dt) {
  float longest = 0.0f;
  for (const SystemDef& s : effect.systems) longest = std::max(longest, s.startLifetime.max);
  return std::min<uint64_t>(uint64_t(std::ceil(double(longest) / double(dt))), 600);
}

} // namespace mirage::particles
