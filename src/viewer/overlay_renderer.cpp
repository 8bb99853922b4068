#include "overlay_renderer.h"

#include <algorithm>
#include <cstddef>
#include <cstring>

#include <imgui.h>

#include "mirage/gpu/commands.h"
#include "mirage/gpu/pipeline.h"

namespace mirage::viewer {

std::unique_ptr<OverlayRenderer> OverlayRenderer::create(gpu::Context& context, VkFormat colorFormat,
                                                         uint32_t framesInFlight) {
  std::unique_ptr<OverlayRenderer> o(new OverlayRenderer(context));
  ImGuiIO& io = ImGui::GetIO();
  unsigned char* pixels = nullptr;
  int width = 0, height = 0;
  io.Fonts->GetTexDataAsRGBA32(&pixels, &width, &height);
  o->font_ = gpu::createImage2D(context, uint32_t(width), uint32_t(height), VK_FORMAT_R8G8B8A8_UNORM,
                                VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, "overlay font");
  gpu::uploadTextureRGBA8(context, o->font_, pixels, uint32_t(width), uint32_t(height), 1);

  VkSamplerCreateInfo si{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  si.magFilter = si.minFilter = VK_FILTER_LINEAR;
  si.addressModeU = si.addressModeV = si.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  si.maxLod = VK_LOD_CLAMP_NONE;
  VkSampler sampler;
  MIRAGE_VK_CHECK(vkCreateSampler(context.device(), &si, nullptr, &sampler));
  o->sampler_ = gpu::Unique<VkSampler>(context.device(), sampler);

  VkDescriptorSetLayoutBinding binding{0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_FRAGMENT_BIT,
                                       nullptr};
  o->set_ = gpu::createDescriptorSet(context, {&binding, 1});
  VkDescriptorImageInfo image{sampler, o->font_.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  gpu::writeImageDescriptors(context, o->set_.set, 0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, {&image, 1});
  io.Fonts->SetTexID(ImTextureID(intptr_t(1))); // one texture: any non-null id

  o->layout_ = gpu::createPipelineLayout(context, {o->set_.layout.get()}, 16, VK_SHADER_STAGE_VERTEX_BIT);
  gpu::GraphicsPipelineDesc d;
  d.vertexShader = "overlay.vert";
  d.fragmentShader = "overlay.frag";
  d.layout = o->layout_;
  d.bindings = {{0, sizeof(ImDrawVert), VK_VERTEX_INPUT_RATE_VERTEX}};
  d.attributes = {{0, 0, VK_FORMAT_R32G32_SFLOAT, uint32_t(offsetof(ImDrawVert, pos))},
                  {1, 0, VK_FORMAT_R32G32_SFLOAT, uint32_t(offsetof(ImDrawVert, uv))},
                  {2, 0, VK_FORMAT_R8G8B8A8_UNORM, uint32_t(offsetof(ImDrawVert, col))}};
  d.colorFormats = {colorFormat};
  d.depthWrite = false;
  d.alphaBlend = true;
  o->pipeline_ = gpu::createGraphicsPipeline(context, d);
  o->frames_.resize(framesInFlight);
  return o;
}

OverlayRenderer::~OverlayRenderer() = default;

void OverlayRenderer::record(VkCommandBuffer cmd, uint32_t slot, VkImageView target, VkExtent2D extent,
                             const ImDrawData* data) {
  VkRenderingAttachmentInfo color{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  color.imageView = target;
  color.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  color.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;
  color.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
  ri.renderArea = {{0, 0}, extent};
  ri.layerCount = 1;
  ri.colorAttachmentCount = 1;
  ri.pColorAttachments = &color;
  vkCmdBeginRendering(cmd, &ri);
  if (data && data->TotalVtxCount > 0) {
    // Grow this slot's buffers to the frame's size (the previous use of the slot has finished).
    Buffers& b = frames_[slot];
    size_t vertexBytes = size_t(data->TotalVtxCount) * sizeof(ImDrawVert);
    size_t indexBytes = size_t(data->TotalIdxCount) * sizeof(ImDrawIdx);
    if (!b.vertices || b.vertices.size() < vertexBytes)
      b.vertices = gpu::createBuffer(context_, std::max<size_t>(vertexBytes * 2, 64 << 10),
                                     VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, gpu::MemoryUsage::Upload, "overlay vertices");
    if (!b.indices || b.indices.size() < indexBytes)
      b.indices = gpu::createBuffer(context_, std::max<size_t>(indexBytes * 2, 64 << 10),
                                    VK_BUFFER_USAGE_INDEX_BUFFER_BIT, gpu::MemoryUsage::Upload, "overlay indices");
    uint8_t* v = b.vertices.mapped();
    uint8_t* i = b.indices.mapped();
    for (int n = 0; n < data->CmdListsCount; ++n) {
      const ImDrawList* list = data->CmdLists[n];
      std::memcpy(v, list->VtxBuffer.Data, size_t(list->VtxBuffer.Size) * sizeof(ImDrawVert));
      std::memcpy(i, list->IdxBuffer.Data, size_t(list->IdxBuffer.Size) * sizeof(ImDrawIdx));
      v += size_t(list->VtxBuffer.Size) * sizeof(ImDrawVert);
      i += size_t(list->IdxBuffer.Size) * sizeof(ImDrawIdx);
    }

    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout_, 0, 1, &set_.set, 0, nullptr);
    VkDeviceSize zero = 0;
    VkBuffer vb = b.vertices.handle();
    vkCmdBindVertexBuffers(cmd, 0, 1, &vb, &zero);
    vkCmdBindIndexBuffer(cmd, b.indices.handle(), 0,
                         sizeof(ImDrawIdx) == 2 ? VK_INDEX_TYPE_UINT16 : VK_INDEX_TYPE_UINT32);
    vkCmdSetCullMode(cmd, VK_CULL_MODE_NONE);
    vkCmdSetFrontFace(cmd, VK_FRONT_FACE_COUNTER_CLOCKWISE);
    gpu::cmdSetFullViewport(cmd, extent.width, extent.height);
    float push[4] = {2.0f / data->DisplaySize.x, 2.0f / data->DisplaySize.y, 0.0f, 0.0f};
    push[2] = -1.0f - data->DisplayPos.x * push[0];
    push[3] = -1.0f - data->DisplayPos.y * push[1];
    vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_VERTEX_BIT, 0, sizeof push, push);

    // Clip rectangles are in display coordinates; the framebuffer may be scaled (HiDPI).
    ImVec2 off = data->DisplayPos, scale = data->FramebufferScale;
    int32_t vertexBase = 0;
    uint32_t indexBase = 0;
    for (int n = 0; n < data->CmdListsCount; ++n) {
      const ImDrawList* list = data->CmdLists[n];
      for (const ImDrawCmd& c : list->CmdBuffer) {
        if (c.UserCallback) continue; // the viewer adds none
        float x0 = std::max((c.ClipRect.x - off.x) * scale.x, 0.0f);
        float y0 = std::max((c.ClipRect.y - off.y) * scale.y, 0.0f);
        float x1 = std::min((c.ClipRect.z - off.x) * scale.x, float(extent.width));
        float y1 = std::min((c.ClipRect.w - off.y) * scale.y, float(extent.height));
        if (x1 <= x0 || y1 <= y0) continue;
        VkRect2D scissor{{int32_t(x0), int32_t(y0)}, {uint32_t(x1 - x0), uint32_t(y1 - y0)}};
        vkCmdSetScissor(cmd, 0, 1, &scissor);
        vkCmdDrawIndexed(cmd, c.ElemCount, 1, indexBase + c.IdxOffset, vertexBase + int32_t(c.VtxOffset), 0);
      }
      vertexBase += list->VtxBuffer.Size;
      indexBase += uint32_t(list->IdxBuffer.Size);
    }
  }
  vkCmdEndRendering(cmd);
}

} // namespace mirage::viewer
