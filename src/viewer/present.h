#pragma once
// How a rendered frame reaches the swapchain image (docs/viewer.md "Frames in flight"):
// - GPU path (scenes with a record path): the scene's colour target (RGBA16F, linear) is encoded
//   to sRGB bytes in the swapchain's channel order by a compute pass and copied into the swapchain
//   image, in the frame's own command buffer: no readback.
// - Readback path (other scenes, and frames written to PNG): the CPU sRGB image goes through a
//   per-frame-in-flight staging buffer into the image (one copy, channels swizzled on the CPU when
//   the swapchain is BGRA).
#include <cstdint>
#include <vector>

#include "mirage/core/image.h"
#include "mirage/gpu/context.h"
#include "mirage/gpu/deletion_queue.h"
#include "mirage/gpu/memory.h"
#include "mirage/gpu/vk.h"
#include "mirage/gpu/swapchain.h"

namespace mirage::viewer {

struct PresentStaging {
  std::vector<gpu::Buffer> buffers; // one per frame slot, grown on demand
};

// Records: image UNDEFINED -> copy of `image` (clipped to the extent; the rest cleared when the
// image is smaller) -> COLOR_ATTACHMENT_OPTIMAL for the overlay.
void cmdCopyFrameToSwapchain(gpu::Context& context, PresentStaging& staging, const gpu::Swapchain::Frame& frame,
                             VkFormat format, const ImageRGBA8& image);
struct TargetBlit {
  VkFormat format = VK_FORMAT_UNDEFINED; // the swapchain format when the GPU path serves it; else UNDEFINED
  gpu::Unique<VkPipelineLayout> layout;  // present_srgb.comp: push constants only
  gpu::Unique<VkPipeline> pipeline;
  gpu::Buffer half, packed;   // the target's pixels (RGBA16F), then sRGB 8-bit; grown, retired when replaced
  gpu::DeletionQueue retired; // buffers replaced while frames using them were in flight
  uint32_t inFlight = 0;      // slots whose submitted frame uses `half` and `packed`
};
// The GPU path for a swapchain of `format` (B8G8R8A8 or R8G8B8A8 UNORM); else format stays
// UNDEFINED (the viewer reads frames back).
TargetBlit createTargetBlit(gpu::Context& context, VkFormat format);
// A frame of `slot` begins (its previous submission completed): what only it used is freed.
void slotCompleted(TargetBlit& blit, uint32_t slot);
// Records: target GENERAL -> copy into blit.half -> present_srgb.comp into blit.packed -> copy into
// the swapchain image (clipped to the extent; the rest cleared when the target is smaller) ->
// COLOR_ATTACHMENT_OPTIMAL for the overlay. (vkCmdBlitImage would encode sRGB by itself, but
// lavapipe's blit from RGBA16F returned the background colour for every pixel:
// tests/viewer/present_test.cpp.)
void cmdBlitTargetToSwapchain(gpu::Context& context, TargetBlit& blit, const gpu::Swapchain::Frame& frame,
                              const gpu::Image& target);
// Records: COLOR_ATTACHMENT_OPTIMAL -> PRESENT_SRC_KHR.
void cmdTransitionForPresent(VkCommandBuffer cmd, VkImage image);

} // namespace mirage::viewer
