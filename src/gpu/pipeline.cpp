#include "mirage/gpu/pipeline.h"

#include <string>
#include <vector>

#include <fmt/format.h>

#include "mirage/gpu/context.h"
#include "mirage/gpu/shaders.h"

namespace mirage::gpu {

namespace {

// The driver's statistics of each executable of `pipeline` (e.g. NVIDIA: register count, shared
// memory), one stderr line per executable; pipelines are created with CAPTURE_STATISTICS when
// Context::pipelineStatistics() (MIRAGE_PIPELINE_STATS).
void printPipelineStatistics(Context& context, VkPipeline pipeline, std::string_view name) {
  VkPipelineInfoKHR info{VK_STRUCTURE_TYPE_PIPELINE_INFO_KHR, nullptr, pipeline};
  uint32_t n = 0;
  if (vkGetPipelineExecutablePropertiesKHR(context.device(), &info, &n, nullptr) != VK_SUCCESS) return;
  std::vector<VkPipelineExecutablePropertiesKHR> executables(n, {VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_PROPERTIES_KHR});
  vkGetPipelineExecutablePropertiesKHR(context.device(), &info, &n, executables.data());
  for (uint32_t i = 0; i < n; ++i) {
    VkPipelineExecutableInfoKHR ei{VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_INFO_KHR, nullptr, pipeline, i};
    uint32_t m = 0;
    vkGetPipelineExecutableStatisticsKHR(context.device(), &ei, &m, nullptr);
    std::vector<VkPipelineExecutableStatisticKHR> stats(m, {VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_STATISTIC_KHR});
    vkGetPipelineExecutableStatisticsKHR(context.device(), &ei, &m, stats.data());
    std::string line = fmt::format("pipeline {} [{}]:", name, executables[i].name);
    for (const VkPipelineExecutableStatisticKHR& st : stats) {
      switch (st.format) {
      case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_BOOL32_KHR:
        line += fmt::format(" {}={}", st.name, st.value.b32);
        break;
      case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_INT64_KHR:
        line += fmt::format(" {}={}", st.name, st.value.i64);
        break;
      case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_UINT64_KHR:
        line += fmt::format(" {}={}", st.name, st.value.u64);
        break;
      case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_FLOAT64_KHR:
        line += fmt::format(" {}={}", st.name, st.value.f64);
        break;
      default:
        break;
      }
    }
    std::fprintf(stderr, "%s\n", line.c_str());
  }
}

} // namespace

Unique<VkShaderModule> createShaderModule(Context& context, std::string_view name) {
  auto code = shaderCode(name);
  if (code.empty()) {
    std::fprintf(stderr, "mirage: fatal: shader '%.*s' is not embedded in this build\n", int(name.size()), name.data());
    std::abort();
  }
  VkShaderModuleCreateInfo ci{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  ci.codeSize = code.size_bytes();
  ci.pCode = code.data();
  VkShaderModule module;
  MIRAGE_VK_CHECK(vkCreateShaderModule(context.device(), &ci, nullptr, &module));
  return Unique<VkShaderModule>(context.device(), module);
}

Unique<VkPipeline> createGraphicsPipeline(Context& context, const GraphicsPipelineDesc& d) {
  bool mesh = !d.meshShader.empty();
  Unique<VkShaderModule> vs = createShaderModule(context, mesh ? d.meshShader : d.vertexShader);
  Unique<VkShaderModule> gs, fs;
  std::vector<VkPipelineShaderStageCreateInfo> stages;
  stages.push_back({VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0,
                    mesh ? VK_SHADER_STAGE_MESH_BIT_EXT : VK_SHADER_STAGE_VERTEX_BIT, vs, "main", nullptr});
  if (!d.geometryShader.empty()) {
    gs = createShaderModule(context, d.geometryShader);
    stages.push_back({VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_GEOMETRY_BIT, gs,
                      "main", nullptr});
  }
  if (!d.fragmentShader.empty()) {
    fs = createShaderModule(context, d.fragmentShader);
    stages.push_back({VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_FRAGMENT_BIT, fs,
                      "main", nullptr});
  }

  VkPipelineVertexInputStateCreateInfo vi{VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
  vi.vertexBindingDescriptionCount = uint32_t(d.bindings.size());
  vi.pVertexBindingDescriptions = d.bindings.data();
  vi.vertexAttributeDescriptionCount = uint32_t(d.attributes.size());
  vi.pVertexAttributeDescriptions = d.attributes.data();
  VkPipelineInputAssemblyStateCreateInfo ia{VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
  ia.topology = d.topology;
  VkPipelineViewportStateCreateInfo vp{VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
  vp.viewportCount = 1;
  vp.scissorCount = 1;
  VkPipelineRasterizationStateCreateInfo rs{VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
  rs.polygonMode = VK_POLYGON_MODE_FILL;
  rs.lineWidth = 1.0f;
  VkPipelineMultisampleStateCreateInfo ms{VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
  ms.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  VkPipelineDepthStencilStateCreateInfo ds{VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO};
  ds.depthTestEnable = d.depthFormat != VK_FORMAT_UNDEFINED;
  ds.depthWriteEnable = d.depthWrite;
  ds.depthCompareOp = d.depthCompare;
  std::vector<VkPipelineColorBlendAttachmentState> blends(d.colorFormats.size());
  for (auto& b : blends) {
    b.colorWriteMask =
        VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT | VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
    if (d.alphaBlend) {
      b.blendEnable = VK_TRUE;
      b.srcColorBlendFactor = VK_BLEND_FACTOR_SRC_ALPHA;
      b.dstColorBlendFactor = VK_BLEND_FACTOR_ONE_MINUS_SRC_ALPHA;
      b.colorBlendOp = VK_BLEND_OP_ADD;
      b.srcAlphaBlendFactor = VK_BLEND_FACTOR_ONE;
      b.dstAlphaBlendFactor = VK_BLEND_FACTOR_ONE_MINUS_SRC_ALPHA;
      b.alphaBlendOp = VK_BLEND_OP_ADD;
    }
  }
  for (size_t i = 0; i < d.colorBlends.size() && i < blends.size(); ++i) blends[i] = d.colorBlends[i];
  VkPipelineColorBlendStateCreateInfo cb{VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
  cb.attachmentCount = uint32_t(blends.size());
  cb.pAttachments = blends.data();
  VkDynamicState dynamic[] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR, VK_DYNAMIC_STATE_CULL_MODE,
                              VK_DYNAMIC_STATE_FRONT_FACE};
  VkPipelineDynamicStateCreateInfo dyn{VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO};
  dyn.dynamicStateCount = 4;
  dyn.pDynamicStates = dynamic;
  VkPipelineRenderingCreateInfo ri{VK_STRUCTURE_TYPE_PIPELINE_RENDERING_CREATE_INFO};
  ri.colorAttachmentCount = uint32_t(d.colorFormats.size());
  ri.pColorAttachmentFormats = d.colorFormats.data();
  ri.depthAttachmentFormat = d.depthFormat;
  ri.viewMask = d.viewMask;

  VkGraphicsPipelineCreateInfo ci{VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO, &ri};
  ci.stageCount = uint32_t(stages.size());
  ci.pStages = stages.data();
  ci.pVertexInputState = mesh ? nullptr : &vi; // mesh pipelines have no vertex input stage
  ci.pInputAssemblyState = mesh ? nullptr : &ia;
  ci.pViewportState = &vp;
  ci.pRasterizationState = &rs;
  ci.pMultisampleState = &ms;
  ci.pDepthStencilState = &ds;
  ci.pColorBlendState = &cb;
  ci.pDynamicState = &dyn;
  ci.layout = d.layout;
  VkPipeline pipeline;
  if (context.pipelineStatistics()) ci.flags |= VK_PIPELINE_CREATE_CAPTURE_STATISTICS_BIT_KHR;
  MIRAGE_VK_CHECK(vkCreateGraphicsPipelines(context.device(), VK_NULL_HANDLE, 1, &ci, nullptr, &pipeline));
  if (context.pipelineStatistics()) printPipelineStatistics(context, pipeline, mesh ? d.meshShader : d.vertexShader);
  return Unique<VkPipeline>(context.device(), pipeline);
}

Unique<VkPipeline> createComputePipeline(Context& context, std::string_view shader, VkPipelineLayout layout) {
  return createComputePipeline(context, shader, layout, {});
}

Unique<VkPipeline> createComputePipeline(Context& context, std::string_view shader, VkPipelineLayout layout,
                                         std::span<const uint32_t> specialization) {
  Unique<VkShaderModule> cs = createShaderModule(context, shader);
  std::vector<VkSpecializationMapEntry> entries;
  for (uint32_t i = 0; i < specialization.size(); ++i)
    entries.push_back({i, uint32_t(i * sizeof(uint32_t)), sizeof(uint32_t)});
  VkSpecializationInfo info{uint32_t(entries.size()), entries.data(), specialization.size_bytes(),
                            specialization.data()};
  VkComputePipelineCreateInfo ci{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
  ci.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO,
              nullptr,
              0,
              VK_SHADER_STAGE_COMPUTE_BIT,
              cs,
              "main",
              specialization.empty() ? nullptr : &info};
  ci.layout = layout;
  if (context.pipelineStatistics()) ci.flags |= VK_PIPELINE_CREATE_CAPTURE_STATISTICS_BIT_KHR;
  VkPipeline pipeline;
  MIRAGE_VK_CHECK(vkCreateComputePipelines(context.device(), VK_NULL_HANDLE, 1, &ci, nullptr, &pipeline));
  if (context.pipelineStatistics()) printPipelineStatistics(context, pipeline, shader);
  return Unique<VkPipeline>(context.device(), pipeline);
}

Unique<VkPipelineLayout> createPipelineLayout(Context& context, const std::vector<VkDescriptorSetLayout>& sets,
                                              uint32_t pushConstantBytes, VkShaderStageFlags pushStages) {
  VkPushConstantRange range{pushStages, 0, pushConstantBytes};
  VkPipelineLayoutCreateInfo ci{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  ci.setLayoutCount = uint32_t(sets.size());
  ci.pSetLayouts = sets.data();
  ci.pushConstantRangeCount = pushConstantBytes ? 1 : 0;
  ci.pPushConstantRanges = &range;
  VkPipelineLayout layout;
  MIRAGE_VK_CHECK(vkCreatePipelineLayout(context.device(), &ci, nullptr, &layout));
  return Unique<VkPipelineLayout>(context.device(), layout);
}

} // namespace mirage::gpu
