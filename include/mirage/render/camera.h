#pragma once
// Cameras: explicit eye/target/fov, or an automatic 3/4 view that frames the scene bounds.
#include <string_view>

#include <glm/glm.hpp>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"

namespace mirage::render {

struct Camera {
  glm::vec3 eye{0.0f, 0.0f, 5.0f};
  glm::vec3 target{0.0f};
  glm::vec3 up{0.0f, 1.0f, 0.0f};
  float fovYDegrees = 60.0f; // vertical field of view
  float znear = 0.0f;        // 0: derived from the scene bounds
  float zfar = 0.0f;         // 0: derived from the scene bounds

  glm::mat4 view() const;
  // Reverse-Z (near -> 1, far -> 0), Vulkan clip space (y down), depth in [0, 1].
  glm::mat4 projection(float aspect) const;
};

// "eye=x,y,z,target=x,y,z,fov=60[,up=x,y,z]" (keys in any order; eye and target required).
Result<Camera> parseCamera(std::string_view text);

// 3/4 view from above-front-right at the nearest distance where the whole bounding box projects
// inside the view (5% margin), with near/far planes bracketing the bounds.
Camera autoCamera(const Bounds& bounds, float aspect, float fovYDegrees = 60.0f);

// Fill znear/zfar when zero, from the bounds seen by this camera (near plane never behind the eye).
Camera withClipPlanes(Camera camera, const Bounds& bounds);

} // namespace mirage::render
