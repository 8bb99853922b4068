#include "mirage/gpu/swapchain.h"

#include <algorithm>

#include <fmt/format.h>

#include "mirage/gpu/context.h"

namespace mirage::gpu {

const char* toString(PresentMode mode) {
  switch (mode) {
  case PresentMode::Fifo:
    return "fifo";
  case PresentMode::Mailbox:
    return "mailbox";
  case PresentMode::Immediate:
    return "immediate";
  }
  return "?";
}

Result<PresentMode> parsePresentMode(std::string_view text) {
  for (PresentMode m : {PresentMode::Fifo, PresentMode::Mailbox, PresentMode::Immediate})
    if (text == toString(m)) return m;
  return Error{fmt::format("--present '{}': expected fifo, mailbox or immediate", text)};
}

VkPresentModeKHR choosePresentMode(PresentMode wanted, const std::vector<VkPresentModeKHR>& available) {
  VkPresentModeKHR mode = wanted == PresentMode::Mailbox     ? VK_PRESENT_MODE_MAILBOX_KHR
                          : wanted == PresentMode::Immediate ? VK_PRESENT_MODE_IMMEDIATE_KHR
                                                             : VK_PRESENT_MODE_FIFO_KHR;
  return std::find(available.begin(), available.end(), mode) != available.end() ? mode : VK_PRESENT_MODE_FIFO_KHR;
}

VkSurfaceFormatKHR chooseSurfaceFormat(const std::vector<VkSurfaceFormatKHR>& available) {
  for (VkFormat f : {VK_FORMAT_B8G8R8A8_UNORM, VK_FORMAT_R8G8B8A8_UNORM})
    for (const VkSurfaceFormatKHR& s : available)
      if (s.format == f && s.colorSpace == VK_COLOR_SPACE_SRGB_NONLINEAR_KHR) return s;
  return available.empty() ? VkSurfaceFormatKHR{} : available[0];
}

Swapchain::Swapchain(Context& context, VkSurfaceKHR surface) : context_(context), surface_(surface) {}

Result<std::unique_ptr<Swapchain>> Swapchain::create(Context& context, VkSurfaceKHR surface, VkExtent2D extent,
                                                     const SwapchainOptions& options) {
  std::unique_ptr<Swapchain> s(new Swapchain(context, surface)); // owns the surface from here on
  VkBool32 supported = VK_FALSE;
  vkGetPhysicalDeviceSurfaceSupportKHR(context.physicalDevice(), context.queueFamily(), surface, &supported);
  if (!supported)
    return Error{fmt::format("vulkan: the queue of '{}' cannot present to this window", context.caps().name)};
  uint32_t n = 0;
  vkGetPhysicalDeviceSurfaceFormatsKHR(context.physicalDevice(), surface, &n, nullptr);
  std::vector<VkSurfaceFormatKHR> formats(n);
  vkGetPhysicalDeviceSurfaceFormatsKHR(context.physicalDevice(), surface, &n, formats.data());
  s->format_ = chooseSurfaceFormat(formats);
  if (s->format_.format == VK_FORMAT_UNDEFINED) return Error{"vulkan: the window surface offers no image format"};
  s->requested_ = options.presentMode;
  s->framesInFlight_ = std::clamp(options.framesInFlight, 1u, kMaxFramesInFlight);

  VkDevice device = context.device();
  VkCommandPoolCreateInfo pi{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pi.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pi.queueFamilyIndex = context.queueFamily();
  VkCommandPool pool;
  MIRAGE_VK_CHECK(vkCreateCommandPool(device, &pi, nullptr, &pool));
  s->pool_ = Unique<VkCommandPool>(device, pool);
  for (uint32_t i = 0; i < s->framesInFlight_; ++i) {
    Slot& slot = s->slots_[i];
    VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    ai.commandPool = pool;
    ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    ai.commandBufferCount = 1;
    MIRAGE_VK_CHECK(vkAllocateCommandBuffers(device, &ai, &slot.cmd));
    VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    fi.flags = VK_FENCE_CREATE_SIGNALED_BIT; // the first wait returns at once
    VkFence fence;
    MIRAGE_VK_CHECK(vkCreateFence(device, &fi, nullptr, &fence));
    slot.done = Unique<VkFence>(device, fence);
    VkSemaphoreCreateInfo si{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
    VkSemaphore sem;
    MIRAGE_VK_CHECK(vkCreateSemaphore(device, &si, nullptr, &sem));
    slot.acquired = Unique<VkSemaphore>(device, sem);
  }
  if (extent.width && extent.height)
    if (auto st = s->recreate(extent); !st) return st.error();
  return s;
}

Swapchain::~Swapchain() {
  waitIdle();
  views_.clear();
  rendered_.clear();
  swapchain_.reset();
  if (surface_) vkDestroySurfaceKHR(context_.instance(), surface_, nullptr);
}

void Swapchain::waitIdle() { vkQueueWaitIdle(context_.queue()); }

void Swapchain::setPresentMode(PresentMode mode) {
  if (mode == requested_) return;
  requested_ = mode;
  stale_ = true;
}

Status Swapchain::recreate(VkExtent2D wanted) {
  // Images of the old swapchain may still be read by a pending present or submission.
  waitIdle();
  VkPhysicalDevice pd = context_.physicalDevice();
  VkSurfaceCapabilitiesKHR caps;
  MIRAGE_VK_CHECK(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(pd, surface_, &caps));
  // A current extent of 0xFFFFFFFF means the surface takes the swapchain's size (X11 reports the window's).
  VkExtent2D extent = caps.currentExtent.width != UINT32_MAX ? caps.currentExtent : wanted;
  extent.width = std::clamp(extent.width, caps.minImageExtent.width, caps.maxImageExtent.width);
  extent.height = std::clamp(extent.height, caps.minImageExtent.height, caps.maxImageExtent.height);
  if (extent.width == 0 || extent.height == 0) return Ok{}; // minimized: stays stale
  uint32_t n = 0;
  vkGetPhysicalDeviceSurfacePresentModesKHR(pd, surface_, &n, nullptr);
  std::vector<VkPresentModeKHR> modes(n);
  vkGetPhysicalDeviceSurfacePresentModesKHR(pd, surface_, &n, modes.data());
  presentMode_ = choosePresentMode(requested_, modes);
  uint32_t images = std::max(caps.minImageCount + 1, framesInFlight_);
  if (caps.maxImageCount) images = std::min(images, caps.maxImageCount);

  VkSwapchainCreateInfoKHR ci{VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR};
  ci.surface = surface_;
  ci.minImageCount = images;
  ci.imageFormat = format_.format;
  ci.imageColorSpace = format_.colorSpace;
  ci.imageExtent = extent;
  ci.imageArrayLayers = 1;
  // Transfer: the rendered image is copied in; colour attachment: the overlay draws on top.
  ci.imageUsage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
  ci.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;
  ci.preTransform = caps.currentTransform;
  ci.compositeAlpha = (caps.supportedCompositeAlpha & VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR)
                          ? VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR
                          : VkCompositeAlphaFlagBitsKHR(caps.supportedCompositeAlpha & -caps.supportedCompositeAlpha);
  ci.presentMode = presentMode_;
  ci.clipped = VK_TRUE;
  ci.oldSwapchain = swapchain_.get();
  if ((caps.supportedUsageFlags & ci.imageUsage) != ci.imageUsage)
    return Error{"vulkan: the window surface's images cannot be transfer and colour targets"};
  VkDevice device = context_.device();
  VkSwapchainKHR handle;
  VkResult r = vkCreateSwapchainKHR(device, &ci, nullptr, &handle);
  if (r != VK_SUCCESS) return Error{fmt::format("vulkan: vkCreateSwapchainKHR failed ({})", toString(r))};
  views_.clear();
  rendered_.clear();
  swapchain_ = Unique<VkSwapchainKHR>(device, handle);
  extent_ = extent;

  vkGetSwapchainImagesKHR(device, handle, &n, nullptr);
  images_.resize(n);
  vkGetSwapchainImagesKHR(device, handle, &n, images_.data());
  for (VkImage image : images_) {
    VkImageViewCreateInfo vi{VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    vi.image = image;
    vi.viewType = VK_IMAGE_VIEW_TYPE_2D;
    vi.format = format_.format;
    vi.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    VkImageView view;
    MIRAGE_VK_CHECK(vkCreateImageView(device, &vi, nullptr, &view));
    views_.emplace_back(device, view);
    VkSemaphoreCreateInfo si{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
    VkSemaphore sem;
    MIRAGE_VK_CHECK(vkCreateSemaphore(device, &si, nullptr, &sem));
    rendered_.emplace_back(device, sem);
  }
  stale_ = false;
  return Ok{};
}

std::optional<Swapchain::Frame> Swapchain::beginFrame(VkExtent2D extent) {
  if (extent.width == 0 || extent.height == 0) return std::nullopt; // minimized
  if (stale_ || !swapchain_ || extent.width != extent_.width || extent.height != extent_.height) {
    if (auto st = recreate(extent); !st) {
      std::fprintf(stderr, "mirage: %s\n", st.error().message.c_str());
      return std::nullopt;
    }
    if (stale_) return std::nullopt;
  }
  Slot& slot = slots_[nextSlot_];
  VkDevice device = context_.device();
  MIRAGE_VK_CHECK(vkWaitForFences(device, 1, slot.done.ptr(), VK_TRUE, UINT64_MAX));
  uint32_t index = 0;
  VkResult r = vkAcquireNextImageKHR(device, swapchain_, UINT64_MAX, slot.acquired, VK_NULL_HANDLE, &index);
  if (r == VK_ERROR_OUT_OF_DATE_KHR) {
    stale_ = true;
    return std::nullopt;
  }
  if (r == VK_SUBOPTIMAL_KHR)
    stale_ = true; // this image still presents; recreate after it
  else
    MIRAGE_VK_CHECK(r);
  MIRAGE_VK_CHECK(vkResetCommandBuffer(slot.cmd, 0));
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  MIRAGE_VK_CHECK(vkBeginCommandBuffer(slot.cmd, &bi));
  Frame f;
  f.cmd = slot.cmd;
  f.slot = nextSlot_;
  f.imageIndex = index;
  f.image = images_[index];
  f.view = views_[index];
  f.extent = extent_;
  return f;
}

void Swapchain::endFrame(const Frame& f) {
  submit(f);
  present(f);
}

bool Swapchain::completed(uint32_t slot) const {
  return slot < framesInFlight_ && vkGetFenceStatus(context_.device(), slots_[slot].done) == VK_SUCCESS;
}

void Swapchain::submit(const Frame& f) {
  Slot& slot = slots_[f.slot];
  VkDevice device = context_.device();
  MIRAGE_VK_CHECK(vkEndCommandBuffer(f.cmd));
  MIRAGE_VK_CHECK(vkResetFences(device, 1, slot.done.ptr()));
  VkSemaphoreSubmitInfo wait{VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO};
  wait.semaphore = slot.acquired;
  // The first write to the image (the copy of the rendered frame) waits for the acquire.
  wait.stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
  VkSemaphoreSubmitInfo signal{VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO};
  signal.semaphore = rendered_[f.imageIndex];
  signal.stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
  VkCommandBufferSubmitInfo cbi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO};
  cbi.commandBuffer = f.cmd;
  VkSubmitInfo2 si{VK_STRUCTURE_TYPE_SUBMIT_INFO_2};
  si.waitSemaphoreInfoCount = 1;
  si.pWaitSemaphoreInfos = &wait;
  si.commandBufferInfoCount = 1;
  si.pCommandBufferInfos = &cbi;
  si.signalSemaphoreInfoCount = 1;
  si.pSignalSemaphoreInfos = &signal;
  MIRAGE_VK_CHECK(vkQueueSubmit2(context_.queue(), 1, &si, slot.done));
}

void Swapchain::present(const Frame& f) {
  VkSwapchainKHR handle = swapchain_.get();
  VkPresentInfoKHR pi{VK_STRUCTURE_TYPE_PRESENT_INFO_KHR};
  pi.waitSemaphoreCount = 1;
  pi.pWaitSemaphores = rendered_[f.imageIndex].ptr();
  pi.swapchainCount = 1;
  pi.pSwapchains = &handle;
  pi.pImageIndices = &f.imageIndex;
  VkResult r = vkQueuePresentKHR(context_.queue(), &pi);
  if (r == VK_ERROR_OUT_OF_DATE_KHR || r == VK_SUBOPTIMAL_KHR)
    stale_ = true;
  else
    MIRAGE_VK_CHECK(r);
  nextSlot_ = (nextSlot_ + 1) % framesInFlight_;
}

} // namespace mirage::gpu
