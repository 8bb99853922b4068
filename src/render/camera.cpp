#include "mirage/render/camera.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <string>

#include <fmt/format.h>
#include <glm/gtc/matrix_transform.hpp>

namespace mirage::render {

glm::mat4 Camera::view() const { return glm::lookAtRH(eye, target, up); }

glm::mat4 Camera::projection(float aspect) const {
  // Reverse-Z: swapping near and far of a [0,1]-depth projection maps near to 1 and far to 0, which
  // spreads float depth precision evenly in distance.
  glm::mat4 p = glm::perspectiveRH_ZO(glm::radians(fovYDegrees), aspect, zfar, znear);
  p[1][1] *= -1.0f; // Vulkan's clip space has y pointing down
  return p;
}

namespace {

bool parseFloats(std::string_view text, float* out, int count) {
  const char* p = text.data();
  const char* end = text.data() + text.size();
  for (int i = 0; i < count; ++i) {
    auto r = std::from_chars(p, end, out[i]);
    if (r.ec != std::errc() || !std::isfinite(out[i])) return false;
    p = r.ptr;
    if (i + 1 < count) {
      if (p == end || *p != ',') return false;
      ++p;
    }
  }
  return p == end;
}

} // namespace

Result<Camera> parseCamera(std::string_view text) {
  Camera c;
  bool haveEye = false, haveTarget = false;
  // Split on "key=" boundaries: values themselves contain commas.
  size_t pos = 0;
  // fmt rather than operator+: GCC 12 warns falsely (-Wrestrict) on chained string concatenation.
  auto bad = [&](const std::string& why) { return Error{fmt::format("--camera '{}': {}", text, why)}; };
  while (pos < text.size()) {
    size_t eq = text.find('=', pos);
    if (eq == std::string_view::npos) return bad("expected key=value");
    std::string_view key = text.substr(pos, eq - pos);
    size_t next = text.size();
    for (size_t i = eq + 1; i < text.size(); ++i) {
      if (text[i] == ',' && i + 1 < text.size() && std::isalpha(static_cast<unsigned char>(text[i + 1]))) {
        next = i;
        break;
      }
    }
    std::string_view value = text.substr(eq + 1, next - eq - 1);
    float v[3];
    if (key == "eye" || key == "target" || key == "up") {
      if (!parseFloats(value, v, 3)) return bad(fmt::format("'{}' needs three numbers x,y,z", key));
      glm::vec3 vec{v[0], v[1], v[2]};
      if (key == "eye")
        c.eye = vec, haveEye = true;
      else if (key == "target")
        c.target = vec, haveTarget = true;
      else
        c.up = vec;
    } else if (key == "fov") {
      if (!parseFloats(value, v, 1) || v[0] <= 1.0f || v[0] >= 179.0f)
        return bad("fov must be a number of degrees in (1, 179)");
      c.fovYDegrees = v[0];
    } else {
      return bad(fmt::format("unknown key '{}' (eye, target, up, fov)", key));
    }
    pos = next == text.size() ? next : next + 1;
  }
  if (!haveEye || !haveTarget) return bad("eye and target are required");
  if (glm::length(c.eye - c.target) <= 0.0f) return bad("eye and target coincide");
  if (glm::length(glm::cross(glm::normalize(c.target - c.eye), glm::normalize(c.up))) < 1e-4f)
    return bad("view direction is parallel to up");
  return c;
}

Camera autoCamera(const Bounds& bounds, float aspect, float fovYDegrees) {
  Camera c;
  c.fovYDegrees = fovYDegrees;
  glm::vec3 center = bounds.empty() ? glm::vec3(0.0f) : bounds.center();
  glm::vec3 dir = glm::normalize(glm::vec3(1.0f, 0.75f, 1.4f)); // from the target towards the eye
  glm::vec3 right = glm::normalize(glm::cross(-dir, c.up));
  glm::vec3 up = glm::cross(right, -dir);
  float tanY = std::tan(glm::radians(fovYDegrees) * 0.5f);
  float tanX = tanY * aspect;
  // The nearest eye distance at which all 8 box corners project inside the frustum: a corner at
  // offset q from the centre has depth d - q.dir, and needs |q.right| <= tanX * depth (same for up).
  float distance = 0.0f;
  if (!bounds.empty()) {
    for (int i = 0; i < 8; ++i) {
      glm::vec3 p{(i & 1) ? bounds.max.x : bounds.min.x, (i & 2) ? bounds.max.y : bounds.min.y,
                  (i & 4) ? bounds.max.z : bounds.min.z};
      glm::vec3 q = p - center;
      float along = glm::dot(q, dir);
      distance = std::max(distance, along + std::abs(glm::dot(q, right)) / tanX);
      distance = std::max(distance, along + std::abs(glm::dot(q, up)) / tanY);
    }
  }
  distance = std::max(distance * 1.05f, 1e-5f); // a small margin around the box
  c.eye = center + dir * distance;
  c.target = center;
  return withClipPlanes(c, bounds);
}

Camera withClipPlanes(Camera c, const Bounds& bounds) {
  if (c.znear > 0.0f && c.zfar > c.znear) return c;
  glm::vec3 center = bounds.empty() ? glm::vec3(0.0f) : bounds.center();
  float radius = std::max(bounds.radius(), 1e-6f);
  float dist = glm::length(c.eye - center);
  float zfar = dist + radius * 1.01f;
  // Reverse-Z keeps precision with a small near plane, so a camera inside the bounds still works.
  float znear = std::max(dist - radius * 1.01f, zfar * 1e-5f);
  if (c.znear <= 0.0f) c.znear = znear;
  if (c.zfar <= c.znear) c.zfar = std::max(zfar, c.znear * 2.0f);
  return c;
}

} // namespace mirage::render
