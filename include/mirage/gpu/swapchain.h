#pragma once
// A swapchain over a VkSurfaceKHR (made by the window system: the gpu library knows no windows),
// with the per-frame-in-flight command buffers, fences and semaphores of a present loop:
//   beginFrame (wait for the slot's fence, acquire an image) -> record into Frame::cmd ->
//   endFrame (submit, present). Out-of-date or suboptimal swapchains are recreated at the extent
// the caller passes next; a 0x0 extent (a minimized window) makes beginFrame return no frame.
#include <memory>
#include <optional>
#include <string_view>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/gpu/vk.h"

namespace mirage::gpu {

class Context;

enum class PresentMode {
  Fifo,      // vsync; always available
  Mailbox,   // no tearing, newest frame wins; falls back to fifo
  Immediate, // no vsync, may tear; falls back to fifo
};
const char* toString(PresentMode mode);
// "fifo", "mailbox" or "immediate"; anything else is an error naming the choices.
Result<PresentMode> parsePresentMode(std::string_view text);
// The Vulkan mode for `wanted` among `available`: wanted when offered, else FIFO (the one every
// surface supports).
VkPresentModeKHR choosePresentMode(PresentMode wanted, const std::vector<VkPresentModeKHR>& available);
// An 8-bit UNORM format (the viewer's images are sRGB-encoded already, so no sRGB view converts
// them twice): B8G8R8A8 or R8G8B8A8 with the sRGB non-linear colour space, else the first offered.
VkSurfaceFormatKHR chooseSurfaceFormat(const std::vector<VkSurfaceFormatKHR>& available);

// Frames the CPU may record ahead of the GPU (2..3).
inline constexpr uint32_t kMaxFramesInFlight = 3;

struct SwapchainOptions {
  PresentMode presentMode = PresentMode::Fifo;
  uint32_t framesInFlight = 2; // clamped to 1..kMaxFramesInFlight
};

class Swapchain {
public:
  struct Frame {
    VkCommandBuffer cmd = VK_NULL_HANDLE; // begun; recorded by the caller, ended by endFrame
    uint32_t slot = 0;                    // frame-in-flight index (per-slot resources of the caller)
    uint32_t imageIndex = 0;
    VkImage image = VK_NULL_HANDLE; // in UNDEFINED layout; endFrame expects PRESENT_SRC_KHR
    VkImageView view = VK_NULL_HANDLE;
    VkExtent2D extent{};
  };

  // Takes ownership of `surface` (destroyed with the swapchain). Errors: the queue cannot present to
  // the surface, or the surface offers no usable format.
  static Result<std::unique_ptr<Swapchain>> create(Context& context, VkSurfaceKHR surface, VkExtent2D extent,
                                                   const SwapchainOptions& options);
  ~Swapchain();
  Swapchain(const Swapchain&) = delete;
  Swapchain& operator=(const Swapchain&) = delete;

  // Waits for the next slot's previous submission, then acquires an image. `extent` is the
  // window's framebuffer size now: a change recreates the swapchain first. No frame (nullopt) when
  // the extent is 0x0 or the swapchain went out of date (call again next iteration).
  std::optional<Frame> beginFrame(VkExtent2D extent);
  // Ends frame.cmd, submits it (waiting for the acquire, signalling the present) and presents:
  // submit() then present() (the viewer times each step).
  void endFrame(const Frame& frame);
  void submit(const Frame& frame);
  void present(const Frame& frame);
  // Whether the slot's last submission finished (its fence, not waited for).
  bool completed(uint32_t slot) const;
  // Takes effect at the next beginFrame (the swapchain is recreated).
  void setPresentMode(PresentMode mode);

  PresentMode requestedPresentMode() const { return requested_; }
  VkPresentModeKHR presentMode() const { return presentMode_; } // the mode in use (after fallback)
  VkFormat format() const { return format_.format; }
  VkExtent2D extent() const { return extent_; }
  uint32_t imageCount() const { return uint32_t(images_.size()); }
  uint32_t framesInFlight() const { return framesInFlight_; }
  // Waits until the GPU finished every submitted frame (before resources they use are freed).
  void waitIdle();

private:
  Swapchain(Context& context, VkSurfaceKHR surface);
  Status recreate(VkExtent2D extent);

  struct Slot {
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    Unique<VkFence> done;         // signalled when the slot's last submission finished
    Unique<VkSemaphore> acquired; // image acquired -> submission may write it
  };

  Context& context_;
  VkSurfaceKHR surface_ = VK_NULL_HANDLE;
  Unique<VkSwapchainKHR> swapchain_;
  Unique<VkCommandPool> pool_;
  std::vector<VkImage> images_;
  std::vector<Unique<VkImageView>> views_;
  std::vector<Unique<VkSemaphore>> rendered_; // per image: submission done -> present may read it
  Slot slots_[kMaxFramesInFlight];
  uint32_t framesInFlight_ = 2;
  uint32_t nextSlot_ = 0;
  VkSurfaceFormatKHR format_{};
  VkExtent2D extent_{};
  PresentMode requested_ = PresentMode::Fifo;
  VkPresentModeKHR presentMode_ = VK_PRESENT_MODE_FIFO_KHR;
  bool stale_ = true; // recreate before the next acquire
};

} // namespace mirage::gpu
