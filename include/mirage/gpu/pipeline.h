#pragma once
// Shader modules from embedded SPIR-V, and small builders for the pipelines Mirage uses
// (dynamic rendering, no render-pass objects).
#include <span>
#include <string_view>
#include <vector>

#include "mirage/gpu/vk.h"

namespace mirage::gpu {

class Context;

// Aborts with the name when the shader is not embedded (a build error, not a user error).
Unique<VkShaderModule> createShaderModule(Context& context, std::string_view name);

struct GraphicsPipelineDesc {
  std::string_view vertexShader;   // embedded names, e.g. "forward.vert"
  std::string_view meshShader;     // instead of vertexShader: a VK_EXT_mesh_shader pipeline (no vertex input)
  std::string_view geometryShader; // optional, after vertexShader (needs the geometryShader feature)
  std::string_view fragmentShader; // empty: depth-only
  VkPipelineLayout layout = VK_NULL_HANDLE;
  std::vector<VkVertexInputBindingDescription> bindings;
  std::vector<VkVertexInputAttributeDescription> attributes;
  std::vector<VkFormat> colorFormats;
  VkFormat depthFormat = VK_FORMAT_UNDEFINED;
  VkCompareOp depthCompare = VK_COMPARE_OP_GREATER; // reverse-Z
  bool depthWrite = true;
  bool alphaBlend = false; // premultiplied-free "over": src*a + dst*(1-a)
  // Per colour format, replacing alphaBlend's state where given (e.g. weighted OIT's accumulation
  // and revealage targets).
  std::vector<VkPipelineColorBlendAttachmentState> colorBlends;
  VkPrimitiveTopology topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  uint32_t viewMask = 0; // multiview: one bit per view rendered in one pass (0: no multiview)
  // Cull mode and front face are dynamic state: one pipeline serves single- and double-sided materials.
};

Unique<VkPipeline> createGraphicsPipeline(Context& context, const GraphicsPipelineDesc& desc);
Unique<VkPipeline> createComputePipeline(Context& context, std::string_view shader, VkPipelineLayout layout);
// With specialization constants: constant_id i takes specialization[i] (32-bit values: uint, int,
// float bits or a VkBool32), so one shader yields variants the compiler folds (e.g. a feature off
// costs no registers).
Unique<VkPipeline> createComputePipeline(Context& context, std::string_view shader, VkPipelineLayout layout,
                                         std::span<const uint32_t> specialization);

Unique<VkPipelineLayout> createPipelineLayout(Context& context, const std::vector<VkDescriptorSetLayout>& sets,
                                              uint32_t pushConstantBytes, VkShaderStageFlags pushStages);

} // namespace mirage::gpu
