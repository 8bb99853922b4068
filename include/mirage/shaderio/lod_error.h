// The LOD error projection, written once for the GPU selection (cluster_select.glsl) and every CPU
// site that must agree with it (reference cuts in tests, the discrete-LOD baseline, the surfel
// prefix size): compiled as GLSL and as C++ (glm), so both evaluate the same operations in the same
// order and the CPU reference matches the GPU bit for bit.
#ifndef MIRAGE_SHADERIO_LOD_ERROR_H
#define MIRAGE_SHADERIO_LOD_ERROR_H

#ifdef __cplusplus
#include <glm/glm.hpp>
namespace mirage::shaderio {
using glm::abs;
using glm::acos;
using glm::asin;
using glm::clamp;
using glm::dot;
using glm::isinf;
using glm::length;
using glm::max;
using glm::min;
using glm::uintBitsToFloat;
using vec3 = glm::vec3;
#define MIRAGE_SHARED inline
#else
#define MIRAGE_SHARED
#endif

// Pixels per world unit at distance 1 of a perspective projection whose proj[1][1] is `proj11`
// (1 / tan(fovY / 2)) on a target `height` pixels high.
MIRAGE_SHARED float projectionScale(float proj11, float height) { return abs(proj11) * 0.5f * height; }

// An object-space error of a bounding sphere, projected to pixels at the sphere's nearest point:
// error * scale / max(dist - radius * scale, znear) * pixelScale, where `center` is the sphere's
// centre in world space and `scale` the instance's largest axis scale. A camera inside the sphere
// sees an unbounded error (+inf: refine); zero and infinite errors stay as they are (level 0
// cannot refine, roots have no parent). Parent spheres contain their children's and parent errors
// are larger, so the projection stays monotonic from child to parent and a cut stays crack-free.
MIRAGE_SHARED float projectedSphereError(vec3 center, float radius, float error, float scale, vec3 eye, float znear,
                                         float pixelScale) {
  if (error <= 0.0f || isinf(error)) return error;
  float d = length(center - eye) - radius * scale;
  if (d <= 0.0f) return uintBitsToFloat(0x7f800000u);
  return error * scale / max(d, znear) * pixelScale;
}

// Foveation: the LOD threshold tau grows with the eccentricity of a bounding sphere from the gaze
// direction, outside a fovea of `foveaRadius` radians:
//   tau' = tau * (1 + slope * max(0, eccentricity - foveaRadius)),
// linear in angle like the minimum angle of resolution of the eye, MAR(e) = w0 + m * e (Guenter et
// al. 2012, "Foveated 3D graphics": m = 0.022, w0 = 1/48 degree): foveaSlope() is m / MAR(radius),
// so the factor is MAR(e) / MAR(radius), 1 at the fovea's edge. The eccentricity is that of the
// sphere's nearest point (centre angle minus angular radius; 0 with the eye inside): a parent
// sphere containing its children never gets a larger factor, while its error is never smaller, so
// the projected error over tau' stays monotonic from child to parent and the cut stays crack-free.
// Trigonometry differs in the last bits between GLSL and the C++ library: CPU references compare
// this factor to float precision, not bit for bit.
MIRAGE_SHARED float fovealTauScale(vec3 center, float radius, vec3 eye, vec3 gaze, float foveaRadius, float slope) {
  vec3 toCenter = center - eye;
  float d = length(toCenter);
  if (d <= radius) return 1.0f;
  float angle = acos(clamp(dot(toCenter, gaze) / d, -1.0f, 1.0f));
  float eccentricity = max(angle - asin(radius / d), 0.0f);
  return 1.0f + slope * max(eccentricity - foveaRadius, 0.0f);
}

// The largest fovealTauScale of any sphere inside the ball (`center`, `reach`): its nearest point
// is at most the ball's angular radius further from the gaze than the centre (the instance-level
// culling must not drop a level that the per-cluster test would take).
MIRAGE_SHARED float fovealTauScaleMax(vec3 center, float reach, vec3 eye, vec3 gaze, float foveaRadius, float slope) {
  const float pi = 3.14159265359f;
  vec3 toCenter = center - eye;
  float d = length(toCenter);
  float angle = pi;
  if (d > reach) angle = min(acos(clamp(dot(toCenter, gaze) / d, -1.0f, 1.0f)) + asin(reach / d), pi);
  return 1.0f + slope * max(angle - foveaRadius, 0.0f);
}

// The slope of fovealTauScale per radian for a fovea of `foveaRadius` radians (see above).
MIRAGE_SHARED float foveaSlope(float foveaRadius) {
  const float m = 0.022f;                           // MAR growth, degree per degree of eccentricity
  const float w0 = (1.0f / 48.0f) * 0.01745329252f; // MAR at the centre of the fovea, radians
  return m / (w0 + m * foveaRadius);
}

#undef MIRAGE_SHARED
#ifdef __cplusplus
} // namespace mirage::shaderio
#endif

#endif
