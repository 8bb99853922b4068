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
using glm::isinf;
using glm::length;
using glm::max;
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

#undef MIRAGE_SHARED
#ifdef __cplusplus
} // namespace mirage::shaderio
#endif

#endif
