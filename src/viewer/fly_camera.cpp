#include "mirage/viewer/fly_camera.h"

#include <algorithm>
#include <cmath>

namespace mirage::viewer {

glm::vec3 forwardOf(const FlyCamera& c) {
  float cp = std::cos(c.pitch);
  return {cp * std::sin(c.yaw), std::sin(c.pitch), -cp * std::cos(c.yaw)};
}

glm::vec3 rightOf(const FlyCamera& c) { return {std::cos(c.yaw), 0.0f, std::sin(c.yaw)}; }

glm::vec3 moveAxes(bool w, bool a, bool s, bool d, bool q, bool e) {
  return {float(d) - float(a), float(e) - float(q), float(w) - float(s)};
}

bool nextLooking(bool looking, const InputState& in) {
  if (!in.lookButton) return false;
  return looking || !in.overlayMouse;
}

FlyInput flyInput(const InputState& in, bool looking, float seconds) {
  FlyInput out;
  if (!in.overlayKeyboard) out.move = moveAxes(in.forward, in.left, in.back, in.right, in.down, in.up);
  if (looking) out.look = in.mouseDelta;
  if (!in.overlayMouse) out.scroll = in.scroll;
  out.seconds = std::clamp(seconds, 0.0f, kMaxStepSeconds);
  return out;
}

void update(FlyCamera& c, const FlyInput& in) {
  c.yaw = std::remainder(c.yaw + in.look.x * kLookRadiansPerPixel, 2.0f * float(M_PI));
  c.pitch = std::clamp(c.pitch - in.look.y * kLookRadiansPerPixel, -kPitchLimitRadians, kPitchLimitRadians);
  if (in.scroll != 0.0f) c.speed = std::clamp(c.speed * std::pow(kSpeedStepPerNotch, in.scroll), kMinSpeed, kMaxSpeed);
  glm::vec3 step = rightOf(c) * in.move.x + glm::vec3(0.0f, 1.0f, 0.0f) * in.move.y + forwardOf(c) * in.move.z;
  c.position += step * (c.speed * in.seconds);
}

FlyCamera fromCamera(const render::Camera& camera, const Bounds& bounds) {
  FlyCamera c;
  c.position = camera.eye;
  glm::vec3 d = camera.target - camera.eye;
  c.focus = std::max(glm::length(d), 1e-6f);
  d /= c.focus;
  c.pitch = std::clamp(std::asin(std::clamp(d.y, -1.0f, 1.0f)), -kPitchLimitRadians, kPitchLimitRadians);
  c.yaw = std::atan2(d.x, -d.z);
  c.fovYDegrees = camera.fovYDegrees;
  c.speed = std::clamp(bounds.empty() ? 1.0f : 0.5f * bounds.radius(), kMinSpeed, kMaxSpeed);
  return c;
}

render::Camera toCamera(const FlyCamera& c) {
  render::Camera out;
  out.eye = c.position;
  out.target = c.position + c.focus * forwardOf(c);
  out.up = {0.0f, 1.0f, 0.0f};
  out.fovYDegrees = c.fovYDegrees;
  return out;
}

FlyCamera frameScene(const Bounds& bounds, float aspect, float fovYDegrees) {
  return fromCamera(render::autoCamera(bounds, aspect, fovYDegrees), bounds);
}

} // namespace mirage::viewer
