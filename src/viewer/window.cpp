#include "window.h"

// After volk's Vulkan types (window.h): GLFW then declares its Vulkan functions; it loads the
// Vulkan loader itself, so volk's function pointers and GLFW's calls do not meet.
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <algorithm>

#include <fmt/format.h>

namespace mirage::viewer {

namespace {
std::string g_lastError;
void onError(int, const char* description) { g_lastError = description ? description : "unknown error"; }
} // namespace

void onScroll(GLFWwindow* handle, double, double y) {
  if (auto* w = static_cast<Window*>(glfwGetWindowUserPointer(handle))) w->scrollPending_ += float(y);
}

Result<std::unique_ptr<WindowSystem>> WindowSystem::start() {
  glfwSetErrorCallback(onError);
  if (!glfwInit()) return Error{fmt::format("cannot open a window: {}", g_lastError)};
  std::unique_ptr<WindowSystem> system(new WindowSystem());
  if (!glfwVulkanSupported()) return Error{"cannot open a window: GLFW found no Vulkan loader"};
  return system;
}

WindowSystem::~WindowSystem() { glfwTerminate(); }

std::vector<std::string> WindowSystem::instanceExtensions() const {
  uint32_t n = 0;
  const char** names = glfwGetRequiredInstanceExtensions(&n);
  return std::vector<std::string>(names, names + n);
}

Result<std::unique_ptr<Window>> Window::create(uint32_t width, uint32_t height, const std::string& title) {
  glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
  std::unique_ptr<Window> w(new Window());
  w->window_ = glfwCreateWindow(int(width), int(height), title.c_str(), nullptr, nullptr);
  if (!w->window_) return Error{fmt::format("cannot open a window: {}", g_lastError)};
  glfwSetWindowUserPointer(w->window_, w.get());
  // Installed before the overlay's GLFW backend, which chains to it.
  glfwSetScrollCallback(w->window_, onScroll);
  return w;
}

Window::~Window() {
  if (window_) glfwDestroyWindow(window_);
}

Result<VkSurfaceKHR> Window::createSurface(VkInstance instance) const {
  VkSurfaceKHR surface = VK_NULL_HANDLE;
  VkResult r = glfwCreateWindowSurface(instance, window_, nullptr, &surface);
  if (r != VK_SUCCESS)
    return Error{fmt::format("cannot create a Vulkan surface for the window ({})", gpu::toString(r))};
  return surface;
}

VkExtent2D Window::framebufferSize() const {
  int w = 0, h = 0;
  glfwGetFramebufferSize(window_, &w, &h);
  return {uint32_t(std::max(w, 0)), uint32_t(std::max(h, 0))};
}

bool Window::shouldClose() const { return glfwWindowShouldClose(window_); }
void Window::requestClose() { glfwSetWindowShouldClose(window_, GLFW_TRUE); }
void Window::setTitle(const std::string& title) { glfwSetWindowTitle(window_, title.c_str()); }
void Window::waitEvents() { glfwWaitEventsTimeout(0.1); }

void Window::poll() {
  glfwPollEvents();
  for (int key = GLFW_KEY_SPACE; key < PolledInput::kKeys && key <= GLFW_KEY_LAST; ++key)
    input_.setKey(key, glfwGetKey(window_, key) == GLFW_PRESS);
  input_.lookButton = glfwGetMouseButton(window_, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS;
  glm::dvec2 cursor;
  glfwGetCursorPos(window_, &cursor.x, &cursor.y);
  input_.mouseDelta = haveCursor_ ? glm::vec2(cursor - cursor_) : glm::vec2(0.0f);
  cursor_ = cursor;
  haveCursor_ = true;
  input_.scroll = scrollPending_;
  scrollPending_ = 0.0f;
}

void Window::setCursorCaptured(bool captured) {
  if (captured == captured_) return;
  captured_ = captured;
  glfwSetInputMode(window_, GLFW_CURSOR, captured ? GLFW_CURSOR_DISABLED : GLFW_CURSOR_NORMAL);
  haveCursor_ = false; // the position jumps when the mode changes: no delta from it
}

} // namespace mirage::viewer
