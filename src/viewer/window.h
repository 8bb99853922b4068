#pragma once
// The GLFW side of the viewer: the library (its instance extensions), one window without a client
// API, its Vulkan surface, and per-frame input (key states with press edges, mouse motion, scroll).
#include <array>
#include <memory>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "mirage/core/result.h"
#include "mirage/gpu/vk.h"
#include "polled_input.h"

struct GLFWwindow;

namespace mirage::viewer {

// glfwInit / glfwTerminate. Errors: no display (the one line GLFW gives, e.g. "X11: The DISPLAY
// environment variable is missing").
class WindowSystem {
public:
  static Result<std::unique_ptr<WindowSystem>> start();
  ~WindowSystem();
  // The instance extensions a surface of this window system needs (VK_KHR_surface + the platform's).
  std::vector<std::string> instanceExtensions() const;

private:
  WindowSystem() = default;
};

class Window {
public:
  static Result<std::unique_ptr<Window>> create(uint32_t width, uint32_t height, const std::string& title);
  ~Window();
  Window(const Window&) = delete;
  Window& operator=(const Window&) = delete;

  GLFWwindow* handle() const { return window_; }
  Result<VkSurfaceKHR> createSurface(VkInstance instance) const;
  VkExtent2D framebufferSize() const;
  bool shouldClose() const;
  void requestClose();
  void setTitle(const std::string& title);

  // Polls events and updates input() (call once per frame).
  void poll();
  // Sleeps until an event arrives (a minimized window draws nothing).
  void waitEvents();
  const PolledInput& input() const { return input_; }
  // Hidden, unbounded cursor (mouse look) or the normal one.
  void setCursorCaptured(bool captured);

private:
  Window() = default;
  GLFWwindow* window_ = nullptr;
  PolledInput input_;
  glm::dvec2 cursor_{0.0};
  bool haveCursor_ = false;
  float scrollPending_ = 0.0f;
  bool captured_ = false;
  friend void onScroll(GLFWwindow*, double, double);
};

} // namespace mirage::viewer
