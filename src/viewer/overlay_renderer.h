#pragma once
// Draws Dear ImGui's draw data on Mirage's gpu wrappers: one pipeline (dynamic rendering, alpha
// "over" blending, scissor per command), the font atlas as one sampled image, and per-frame-in-
// flight host-visible vertex / index buffers that grow when a frame needs more. Debian's
// libimgui.a Vulkan backend calls vk* prototypes, which under volk are function pointers of the
// same names, so Mirage records the draw lists itself.
#include <memory>
#include <vector>

#include "mirage/gpu/context.h"
#include "mirage/gpu/descriptors.h"
#include "mirage/gpu/memory.h"
#include "mirage/gpu/vk.h"

struct ImDrawData;

namespace mirage::viewer {

class OverlayRenderer {
public:
  // Builds the font atlas of the current ImGui context and uploads it.
  static std::unique_ptr<OverlayRenderer> create(gpu::Context& context, VkFormat colorFormat, uint32_t framesInFlight);
  ~OverlayRenderer();
  // Records `data` into `target` (COLOR_ATTACHMENT_OPTIMAL; its content is kept and drawn over).
  // `slot`'s buffers must be free (the swapchain waited for that frame slot).
  void record(VkCommandBuffer cmd, uint32_t slot, VkImageView target, VkExtent2D extent, const ImDrawData* data);

private:
  explicit OverlayRenderer(gpu::Context& context) : context_(context) {}
  struct Buffers {
    gpu::Buffer vertices, indices;
  };
  gpu::Context& context_;
  gpu::Image font_;
  gpu::Unique<VkSampler> sampler_;
  gpu::DescriptorSet set_;
  gpu::Unique<VkPipelineLayout> layout_;
  gpu::Unique<VkPipeline> pipeline_;
  std::vector<Buffers> frames_;
};

} // namespace mirage::viewer
