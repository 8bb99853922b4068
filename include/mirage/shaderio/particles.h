// Particle simulation (docs/particles.md), written once for the CPU pool (src/particles/simulate.cpp)
// and the GPU compute passes (shaders/particles_*.comp): the flattened effect parameters, a
// particle's state, the renderer's per-particle record, the counter-based random numbers and every
// formula (spawn, one semi-implicit Euler step, the render record). Compiled as GLSL and as C++
// (glm), so both sides run the same operations in the same order; they agree to float precision
// (trigonometry and fused multiply-adds may differ in the last bits), not bit for bit.
#ifndef MIRAGE_SHADERIO_PARTICLES_H
#define MIRAGE_SHADERIO_PARTICLES_H

#ifdef __cplusplus
#include <cstdint>
#include <glm/glm.hpp>
namespace mirage::shaderio {
using glm::abs;
using glm::clamp;
using glm::cos;
using glm::dot;
using glm::floor;
using glm::length;
using glm::max;
using glm::min;
using glm::mix;
using glm::normalize;
using glm::pow;
using glm::sin;
using glm::sqrt;
using uint = uint32_t;
using vec2 = glm::vec2;
using vec3 = glm::vec3;
using vec4 = glm::vec4;
using uvec2 = glm::uvec2;
using mat3 = glm::mat3;
#define MIRAGE_SHARED inline
#define MIRAGE_INOUT(T) T&
#define MIRAGE_OUT(T) T&
#define MIRAGE_IN(T) const T&
#define MIRAGE_UNROLL
#else
#extension GL_EXT_control_flow_attributes : require
// An unroll hint for the driver's compiler: loops over constant bounds then index arrays with
// constants, which stay in registers.
#define MIRAGE_UNROLL [[unroll]]
#define MIRAGE_SHARED
#define MIRAGE_INOUT(T) inout T
#define MIRAGE_OUT(T) out T
#define MIRAGE_IN(T) in T
#endif

// Keys of a curve or gradient (size over lifetime, colour over lifetime, colour over speed).
#define MIRAGE_PARTICLE_KEYS 8
// Invocations per work group of the particle passes.
#define MIRAGE_PARTICLE_GROUP 256

// Emitter shapes (ParticleParams::shape).
#define MIRAGE_SHAPE_SPHERE 0u
#define MIRAGE_SHAPE_HEMISPHERE 1u
#define MIRAGE_SHAPE_CONE 2u
#define MIRAGE_SHAPE_CIRCLE 3u
#define MIRAGE_SHAPE_BOX 4u
#define MIRAGE_SHAPE_EDGE 5u
// Where a box emits (ParticleParams::boxMode).
#define MIRAGE_BOX_VOLUME 0u
#define MIRAGE_BOX_SHELL 1u
#define MIRAGE_BOX_EDGE 2u
// Texture sheet animation (ParticleParams::sheetMode).
#define MIRAGE_SHEET_WHOLE 0u
#define MIRAGE_SHEET_ROW 1u

// Attributes of the random numbers: each draw of a particle has its own stream, so adding a module
// never changes the numbers another module sees.
#define MIRAGE_RND_LIFETIME 0u
#define MIRAGE_RND_SPEED 1u
#define MIRAGE_RND_SIZE 2u
#define MIRAGE_RND_ROTATION 3u
#define MIRAGE_RND_COLOR 4u
#define MIRAGE_RND_SHAPE0 5u     // 5..7: three numbers of the shape sample
#define MIRAGE_RND_DIRECTION0 8u // 8..9: the randomized direction
#define MIRAGE_RND_JITTER0 10u   // 10..12: the randomized position
#define MIRAGE_RND_VELOCITY0 13u // 13..15: velocity over lifetime (per axis)
#define MIRAGE_RND_FORCE0 16u    // 16..18: force over lifetime (per axis)
#define MIRAGE_RND_ANGULAR 19u
#define MIRAGE_RND_FRAME 20u
#define MIRAGE_RND_ROW 21u

// One system's parameters, flattened from an effect file's [[system]] (flattenSystem in
// src/particles/params.cpp). Angles in radians; the emitter transform is folded into shapeToWorld.
struct ParticleParams {
  mat3 shapeToWorld;        // emitter rotation * shape rotation * shape scale
  mat3 directionToWorld;    // emitter rotation * shape rotation (directions are not scaled)
  vec3 origin;              // emitter position + emitter rotation * shape position
  uint shape;               // MIRAGE_SHAPE_*
  float radius;             // sphere, hemisphere, cone base, circle; edge half length
  float radiusThickness;    // 0: the shell only, 1: the whole volume (fraction of the radius emitting)
  float arc;                // radians around +Y (sphere, hemisphere, cone, circle); edge: unused
  float coneAngle;          // radians between +Y and the cone's side
  vec3 boxSize;             // full extents
  uint boxMode;             // MIRAGE_BOX_*
  float randomizeDirection; // 0: the shape's direction, 1: a uniformly random one
  float randomizePosition;  // jitter (world units, each axis in [-r, r])
  vec2 lifetime;            // start lifetime, seconds [min, max]
  vec2 speed;               // start speed [min, max]
  vec2 size;                // start size [min, max]
  vec2 rotation;            // start rotation [min, max]
  vec4 colorMin;            // start colour: mix(colorMin, colorMax, u)
  vec4 colorMax;
  vec3 gravity;     // gravity * gravity modifier, world units / s^2
  vec3 velocityMin; // velocity over lifetime: per axis a random constant in [min, max]
  vec3 velocityMax;
  vec3 forceMin; // force over lifetime (acceleration), per axis a random constant in [min, max]
  vec3 forceMax;
  uint randomVelocity;                 // 1: velocityMin != velocityMax (else velocityMin, no random draws per step)
  uint randomForce;                    // 1: forceMin != forceMax
  vec2 angularVelocity;                // rotation over lifetime, radians / s [min, max]
  uint sizeKeyCount;                   // 0: size constant
  vec2 sizeKeys[MIRAGE_PARTICLE_KEYS]; // (normalized age, multiplier), ascending
  uint colorKeyCount;                  // 0: colour constant
  float colorTimes[MIRAGE_PARTICLE_KEYS];
  vec4 colorKeys[MIRAGE_PARTICLE_KEYS]; // multipliers
  uint speedKeyCount;                   // colour over speed; 0: off
  vec2 speedRange;                      // speeds mapped to 0 and 1
  float speedTimes[MIRAGE_PARTICLE_KEYS];
  vec4 speedColors[MIRAGE_PARTICLE_KEYS];
  uvec2 tiles;       // texture sheet tiles (columns, rows); 1x1: no animation
  uint sheetMode;    // MIRAGE_SHEET_*
  uint sheetRow;     // MIRAGE_SHEET_ROW: the row, unless randomRow
  uint randomRow;    // 1: each particle picks a row
  float sheetCycles; // animation cycles over a lifetime
  vec2 startFrame;   // first frame [min, max] (frames, fractional allowed)
  uint seed;
};

// A live particle's state. `id` is its spawn index in its system: with the seed, it keys every
// random number, so a particle's life is the same whichever slot or thread holds it. The random
// constants of the over-lifetime modules are drawn once at spawn and kept: drawing them every
// step cost 13 ns per particle on the CPU (measured), more than the step itself. Velocity over
// lifetime is a constant added to the velocity at spawn (integrating v + c is integrating v and
// adding c), so it needs no field of its own: 48 bytes a particle, the bytes a step moves.
struct Particle {
  vec3 position;
  float age;         // seconds since spawn
  vec3 velocity;     // start speed + velocity over lifetime, then gravity and forces integrated
  float lifetime;    // dies when age >= lifetime
  vec3 acceleration; // gravity * modifier + force over lifetime
  uint id;
};

// What a renderer draws per particle (camera-facing billboards): the simulation's output.
struct RenderParticle {
  vec3 position;  // world space, billboard centre
  float size;     // world units, the billboard's edge
  float rotation; // radians about the view axis
  uint color;     // RGBA8 (particlePackColor: r in the low byte), straight alpha
  uint frame;     // texture sheet tile, row-major from the top left
  uint id;        // spawn index (stable order for sorting ties)
};

#ifdef __cplusplus
static_assert(sizeof(Particle) == 48, "Particle layout (scalar)");
static_assert(sizeof(RenderParticle) == 32, "RenderParticle layout (scalar)");
#endif

// Push constants of the particle passes (src/particles/gpu_simulation.cpp).
struct ParticlePush {
  uint64_t params;    // ParticleParams
  uint64_t particles; // Particle[capacity]
  uint64_t alive;     // uint[capacity]: 1 while the slot holds a live particle
  uint64_t dead;      // uint[capacity]: free slots (a stack)
  uint64_t counters;  // ParticleCounters
  uint64_t render;    // RenderParticle[capacity] (output pass)
  uint capacity;
  uint emit; // particles this step asks for (emitRequest); fewer when the pool is full
  float dt;
  uint writeRender; // 1: update and emit also append the render records (counter live zeroed before)
};

// Counters of a GPU pool.
struct ParticleCounters {
  uint deadCount; // entries on the dead stack
  uint nextId;    // spawn index of the next particle
  uint emitted;   // particles the last emit pass took (the finish pass pops them)
  uint live;      // slots written by the output pass (compacted)
};

// ---- Random numbers: a counter-based hash of (seed, particle id, attribute). ----

// PCG-style integer hash (Jarzynski and Olano 2020, "Hash functions for GPU rendering").
MIRAGE_SHARED uint particleHash(uint v) {
  uint state = v * 747796405u + 2891336453u;
  uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
  return (word >> 22u) ^ word;
}

// A uniform number in [0, 1) (24 bits) for one attribute of one particle: a particle key
// hash(seed ^ hash(id)), which the compiler computes once for all of a particle's draws, then one
// hash per attribute.
MIRAGE_SHARED float particleRandom(uint seed, uint id, uint attr) {
  uint key = particleHash(seed ^ particleHash(id));
  uint h = particleHash(key ^ (attr * 0x9E3779B9u));
  return float(h >> 8u) * (1.0f / 16777216.0f);
}

// RGBA8 with r in the low byte, each channel round(clamp(c, 0, 1) * 255) as floor(x + 0.5): the
// same on both sides without a rounding library call on the CPU.
MIRAGE_SHARED uint particlePackColor(vec4 c) {
  vec4 v = clamp(c, vec4(0.0f), vec4(1.0f)) * 255.0f + vec4(0.5f);
  return uint(v.x) | (uint(v.y) << 8u) | (uint(v.z) << 16u) | (uint(v.w) << 24u);
}

MIRAGE_SHARED float particleRange(vec2 range, uint seed, uint id, uint attr) {
  return mix(range.x, range.y, particleRandom(seed, id, attr));
}

MIRAGE_SHARED vec3 particleRange3(vec3 lo, vec3 hi, uint seed, uint id, uint attr) {
  return vec3(mix(lo.x, hi.x, particleRandom(seed, id, attr)), mix(lo.y, hi.y, particleRandom(seed, id, attr + 1u)),
              mix(lo.z, hi.z, particleRandom(seed, id, attr + 2u)));
}

// A uniformly distributed unit vector from two uniform numbers.
MIRAGE_SHARED vec3 particleUnitVector(float u, float v) {
  float z = 1.0f - 2.0f * u;
  float r = sqrt(max(0.0f, 1.0f - z * z));
  float phi = 6.28318530718f * v;
  return vec3(r * cos(phi), z, r * sin(phi));
}

// ---- Spawn ----

// A point of the emitter shape in shape space (+Y up) and the direction the particle leaves in.
// Radial shapes draw the radius as radius * (1 - thickness * (1 - cbrt/sqrt(u))) so that a volume
// is uniformly filled and thickness 0 keeps every point on the shell.
MIRAGE_SHARED void particleShapeSample(MIRAGE_IN(ParticleParams) e, uint id, MIRAGE_OUT(vec3) position,
                                       MIRAGE_OUT(vec3) direction) {
  float u0 = particleRandom(e.seed, id, MIRAGE_RND_SHAPE0);
  float u1 = particleRandom(e.seed, id, MIRAGE_RND_SHAPE0 + 1u);
  float u2 = particleRandom(e.seed, id, MIRAGE_RND_SHAPE0 + 2u);
  float phi = e.arc * u1; // angle around +Y, 0 at +X towards +Z
  vec3 around = vec3(cos(phi), 0.0f, sin(phi));
  position = vec3(0.0f);
  direction = vec3(0.0f, 1.0f, 0.0f);
  if (e.shape == MIRAGE_SHAPE_SPHERE || e.shape == MIRAGE_SHAPE_HEMISPHERE) {
    // Height y = cos(polar) uniform in [-1, 1] (sphere) or [0, 1] (hemisphere): uniform on the surface.
    float y = e.shape == MIRAGE_SHAPE_SPHERE ? 1.0f - 2.0f * u0 : 1.0f - u0;
    float ring = sqrt(max(0.0f, 1.0f - y * y));
    direction = vec3(ring * around.x, y, ring * around.z);
    float r = e.radius * (1.0f - e.radiusThickness * (1.0f - pow(u2, 1.0f / 3.0f)));
    position = direction * r;
  } else if (e.shape == MIRAGE_SHAPE_CONE) {
    // From a point of the base disc, along the cone's side direction at that point's distance.
    float t = 1.0f - e.radiusThickness * (1.0f - sqrt(u2));
    position = around * (e.radius * t);
    float a = e.coneAngle * t;
    direction = vec3(sin(a) * around.x, cos(a), sin(a) * around.z);
  } else if (e.shape == MIRAGE_SHAPE_CIRCLE) {
    float t = 1.0f - e.radiusThickness * (1.0f - sqrt(u2));
    position = around * (e.radius * t);
    direction = around;
  } else if (e.shape == MIRAGE_SHAPE_BOX) {
    vec3 p = vec3(u0, u1, u2) - vec3(0.5f);
    if (e.boxMode != MIRAGE_BOX_VOLUME) {
      // Push the largest coordinate onto its face (shell), then the second largest too (edge). Faces
      // are picked as in the unit cube (equally per axis), not in proportion to the box's face areas.
      uint axis = abs(p.x) >= abs(p.y) && abs(p.x) >= abs(p.z) ? 0u : (abs(p.y) >= abs(p.z) ? 1u : 2u);
      p[axis] = p[axis] < 0.0f ? -0.5f : 0.5f;
      if (e.boxMode == MIRAGE_BOX_EDGE) {
        uint second = axis == 0u ? (abs(p.y) >= abs(p.z) ? 1u : 2u)
                                 : (axis == 1u ? (abs(p.x) >= abs(p.z) ? 0u : 2u) : (abs(p.x) >= abs(p.y) ? 0u : 1u));
        p[second] = p[second] < 0.0f ? -0.5f : 0.5f;
      }
    }
    position = p * e.boxSize;
  } else { // MIRAGE_SHAPE_EDGE: a segment along X
    position = vec3((2.0f * u0 - 1.0f) * e.radius, 0.0f, 0.0f);
  }
  if (e.randomizeDirection > 0.0f) {
    vec3 random = particleUnitVector(particleRandom(e.seed, id, MIRAGE_RND_DIRECTION0),
                                     particleRandom(e.seed, id, MIRAGE_RND_DIRECTION0 + 1u));
    vec3 blended = mix(direction, random, e.randomizeDirection);
    direction = dot(blended, blended) > 1e-12f ? normalize(blended) : random;
  }
  position = e.shapeToWorld * position + e.origin;
  direction = normalize(e.directionToWorld * direction);
  if (e.randomizePosition > 0.0f)
    position +=
        (particleRange3(vec3(0.0f), vec3(2.0f), e.seed, id, MIRAGE_RND_JITTER0) - vec3(1.0f)) * e.randomizePosition;
}

MIRAGE_SHARED Particle particleSpawn(MIRAGE_IN(ParticleParams) e, uint id) {
  vec3 position;
  vec3 direction;
  particleShapeSample(e, id, position, direction);
  Particle p;
  p.position = position;
  p.age = 0.0f;
  p.velocity = direction * particleRange(e.speed, e.seed, id, MIRAGE_RND_SPEED) +
               particleRange3(e.velocityMin, e.velocityMax, e.seed, id, MIRAGE_RND_VELOCITY0);
  p.lifetime = particleRange(e.lifetime, e.seed, id, MIRAGE_RND_LIFETIME);
  p.acceleration = e.gravity + particleRange3(e.forceMin, e.forceMax, e.seed, id, MIRAGE_RND_FORCE0);
  p.id = id;
  return p;
}

// ---- One step ----

// Semi-implicit Euler with a fixed dt: the velocity takes the acceleration first, the position
// then moves with the new velocity (velocity over lifetime included since spawn):
//   v' = v + (gravity + force) dt,   x' = x + v' dt,   age' = age + dt.
// Returns false when the particle dies (age' >= lifetime); its state is then meaningless.
MIRAGE_SHARED bool particleStep(MIRAGE_INOUT(Particle) p, float dt) {
  p.age += dt;
  if (p.age >= p.lifetime) return false;
  p.velocity += p.acceleration * dt;
  p.position += p.velocity * dt;
  return true;
}

// ---- Render record ----

// A piecewise linear curve of (t, value) keys at t (clamped to the first and last key). The key
// loops run over all MIRAGE_PARTICLE_KEYS with the count as a condition, not as the bound: unrolled,
// every index is a constant, so a shader keeps the keys in registers. (With the count as the bound,
// a GPU thread copied the parameters' key arrays into local memory to index them, 384 bytes per
// particle and step.)
MIRAGE_SHARED float particleCurve(MIRAGE_IN(ParticleParams) e, float t) {
  uint n = e.sizeKeyCount;
  if (n == 0u) return 1.0f;
  if (t <= e.sizeKeys[0].x) return e.sizeKeys[0].y;
  float v = e.sizeKeys[0].y; // the segment holding t, else the last key
  bool found = false;
  MIRAGE_UNROLL for (uint i = 1u; i < MIRAGE_PARTICLE_KEYS; ++i) {
    if (i >= n || found) continue;
    vec2 a = e.sizeKeys[i - 1u];
    vec2 b = e.sizeKeys[i];
    found = t < b.x;
    v = found ? mix(a.y, b.y, (t - a.x) / max(b.x - a.x, 1e-9f)) : b.y;
  }
  return v;
}

MIRAGE_SHARED vec4 particleGradient(MIRAGE_IN(ParticleParams) e, bool speed, float t) {
  uint n = speed ? e.speedKeyCount : e.colorKeyCount;
  if (n == 0u) return vec4(1.0f);
  float t0 = speed ? e.speedTimes[0] : e.colorTimes[0];
  vec4 v = speed ? e.speedColors[0] : e.colorKeys[0]; // the segment holding t, else the last key
  if (t <= t0) return v;
  bool found = false;
  MIRAGE_UNROLL for (uint i = 1u; i < MIRAGE_PARTICLE_KEYS; ++i) {
    if (i >= n || found) continue;
    float ta = speed ? e.speedTimes[i - 1u] : e.colorTimes[i - 1u];
    float ti = speed ? e.speedTimes[i] : e.colorTimes[i];
    vec4 a = speed ? e.speedColors[i - 1u] : e.colorKeys[i - 1u];
    vec4 b = speed ? e.speedColors[i] : e.colorKeys[i];
    found = t < ti;
    v = found ? mix(a, b, (t - ta) / max(ti - ta, 1e-9f)) : b;
  }
  return v;
}

// Size, rotation, colour and sheet frame of a live particle at its age t = age / lifetime:
//   size = startSize * sizeCurve(t), rotation = startRotation + angularVelocity * age,
//   colour = startColour * colourGradient(t) * speedGradient((|v| - s0) / (s1 - s0)),
//   frame = startFrame + floor(t * cycles * frames) mod frames (frames: whole sheet or one row).
MIRAGE_SHARED RenderParticle particleRender(MIRAGE_IN(ParticleParams) e, MIRAGE_IN(Particle) p) {
  float t = clamp(p.age / p.lifetime, 0.0f, 1.0f);
  RenderParticle r;
  r.position = p.position;
  r.size = particleRange(e.size, e.seed, p.id, MIRAGE_RND_SIZE) * particleCurve(e, t);
  r.rotation = particleRange(e.rotation, e.seed, p.id, MIRAGE_RND_ROTATION) +
               particleRange(e.angularVelocity, e.seed, p.id, MIRAGE_RND_ANGULAR) * p.age;
  vec4 c = mix(e.colorMin, e.colorMax, particleRandom(e.seed, p.id, MIRAGE_RND_COLOR));
  c *= particleGradient(e, false, t);
  if (e.speedKeyCount > 0u) {
    float s = (length(p.velocity) - e.speedRange.x) / max(e.speedRange.y - e.speedRange.x, 1e-9f);
    c *= particleGradient(e, true, clamp(s, 0.0f, 1.0f));
  }
  r.color = particlePackColor(c);
  uint frames = e.sheetMode == MIRAGE_SHEET_ROW ? e.tiles.x : e.tiles.x * e.tiles.y;
  float start = floor(particleRange(e.startFrame, e.seed, p.id, MIRAGE_RND_FRAME));
  uint frame = uint(start + floor(t * e.sheetCycles * float(frames))) % frames;
  if (e.sheetMode == MIRAGE_SHEET_ROW) {
    uint row = e.randomRow != 0u
                   ? min(uint(particleRandom(e.seed, p.id, MIRAGE_RND_ROW) * float(e.tiles.y)), e.tiles.y - 1u)
                   : e.sheetRow;
    frame += row * e.tiles.x;
  }
  r.frame = frame;
  r.id = p.id;
  return r;
}

// A billboard's edge in pixels at view z `z` (negative in front of the eye): |proj[1][1]| / -z
// scales view units to NDC, half the viewport height NDC to pixels. What decides between billboard
// and splat (particle_records.glsl), and a streamed particle's atlas level (stream/particle_looks.h).
MIRAGE_SHARED float particleEdgePixels(float proj11, float viewportHeight, float size, float z) {
  return size * abs(proj11) * 0.5f * viewportHeight / max(-z, 1e-6f);
}

// Billboards narrower than this many pixels are drawn this wide with their alpha divided by the
// area ratio, so sub-pixel sparks and drops keep their average coverage instead of vanishing
// between pixel centres.
#define MIRAGE_PARTICLE_MIN_PIXELS 1.5f
// The factor a billboard of `pixels` edge pixels grows by (1 at and above the minimum).
MIRAGE_SHARED float particleGrow(float pixels) {
  return pixels > 0.0f && pixels < MIRAGE_PARTICLE_MIN_PIXELS ? MIRAGE_PARTICLE_MIN_PIXELS / pixels : 1.0f;
}

#ifdef __cplusplus
} // namespace mirage::shaderio
#endif

#endif
