#pragma once
// How a rendered frame reaches the swapchain image: today the renderers hand back a CPU sRGB image,
// which goes through a per-frame-in-flight staging buffer into the image (one copy, channels
// swizzled on the CPU when the swapchain is BGRA). A GPU-side copy of the renderer's colour target
// replaces this one function.
#include <vector>

#include "mirage/core/image.h"
#include "mirage/gpu/context.h"
#include "mirage/gpu/memory.h"
#include "mirage/gpu/swapchain.h"

namespace mirage::viewer {

struct PresentStaging {
  std::vector<gpu::Buffer> buffers; // one per frame slot, grown on demand
};

// Records: image UNDEFINED -> copy of `image` (clipped to the extent; the rest cleared when the
// image is smaller) -> COLOR_ATTACHMENT_OPTIMAL for the overlay.
void cmdCopyFrameToSwapchain(gpu::Context& context, PresentStaging& staging, const gpu::Swapchain::Frame& frame,
                             VkFormat format, const ImageRGBA8& image);
// Records: COLOR_ATTACHMENT_OPTIMAL -> PRESENT_SRC_KHR.
void cmdTransitionForPresent(VkCommandBuffer cmd, VkImage image);

} // namespace mirage::viewer
