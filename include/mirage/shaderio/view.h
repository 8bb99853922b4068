// The camera of one rendered view, shared by the forward, cluster and surfel renderers (first
// member `camera` of FrameData, ClusterFrame and SurfelRenderFrame) and filled by one C++ function,
// render::viewFrame (camera.h). Written once for C++ and GLSL (scalar block layout).
#ifndef MIRAGE_SHADERIO_VIEW_H
#define MIRAGE_SHADERIO_VIEW_H

#ifdef __cplusplus
#include <glm/glm.hpp>
namespace mirage::shaderio {
using vec2 = glm::vec2;
using vec4 = glm::vec4;
using mat4 = glm::mat4;
#endif

struct ViewFrame {
  mat4 view;        // world -> view
  mat4 proj;        // view -> clip: reverse-Z (near 1, far 0), Vulkan clip space (y down)
  mat4 viewProj;    // proj * view
  mat4 invViewProj; // clip -> world (pixel rays)
  vec4 eye;         // xyz camera position, w 1
  vec4 planes[5];   // world-space frustum planes (left, right, bottom, top, near), xyz.p + w >= 0 inside
  vec2 viewport;    // width, height in pixels
  float znear;
  float pixelScale; // projectionScale (lod_error.h): pixels per world unit at distance 1
};

#ifdef __cplusplus
static_assert(sizeof(ViewFrame) == 4 * 64 + 6 * 16 + 16, "ViewFrame layout");
} // namespace mirage::shaderio
#endif

#endif
