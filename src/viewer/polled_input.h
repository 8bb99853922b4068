#pragma once
// One frame's raw input as Window::poll reads it from GLFW, or as a test scripts it: keys held and
// keys that went down since the previous frame (GLFW codes), the look button, mouse motion, scroll.
#include <array>

#include <glm/glm.hpp>

namespace mirage::viewer {

struct PolledInput {
  static constexpr int kKeys = 512; // above GLFW_KEY_LAST
  std::array<bool, kKeys> down{}, pressed{};
  bool lookButton = false;    // right mouse button held
  glm::vec2 mouseDelta{0.0f}; // pixels since the previous frame (screen y down)
  float scroll = 0.0f;        // notches since the previous frame

  // A key's state this frame: pressed when it is down now and was not the frame before.
  void setKey(int key, bool isDown) {
    if (key < 0 || key >= kKeys) return;
    pressed[size_t(key)] = isDown && !down[size_t(key)];
    down[size_t(key)] = isDown;
  }
  bool keyDown(int key) const { return key >= 0 && key < kKeys && down[size_t(key)]; }
  bool keyPressed(int key) const { return key >= 0 && key < kKeys && pressed[size_t(key)]; }
};

} // namespace mirage::viewer
