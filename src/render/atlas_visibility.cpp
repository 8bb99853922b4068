// The visibility stage's checks, and its hardware method: per camera a depth prepass of opaque and
// MASK geometry, then a marking pass whose fragments (early depth tests) flag their triangle's
// patch; the flags are read back.
#include <cstring>

#include <fmt/format.h>

#include "atlas_shading_impl.h"
#include "forward_impl.h"
#include "mirage/gpu/commands.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

void AtlasShading::Impl::ensureDepth(uint32_t width, uint32_t height) {
  if (depth && width == depthWidth && height == depthHeight) return;
  depth = createImage2D(ctx, width, height, kAtlasDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                        "atlas visibility depth");
  depthWidth = width;
  depthHeight = height;
}

Result<std::vector<uint32_t>> AtlasShading::visibility(std::span<const Camera> cameras, uint32_t width,
                                                       uint32_t height) {
  Impl& d = *impl_;
  if (cameras.empty() || cameras.size() > 2)
    return Error{fmt::format("atlas visibility takes 1 or 2 cameras, not {}", cameras.size())};
  if (width == 0 || height == 0 || width > kMaxRenderDimension || height > kMaxRenderDimension)
    return Error{fmt::format("atlas visibility size {}x{} is outside 1..{}", width, height, kMaxRenderDimension)};
  if (d.patchCount == 0) return std::vector<uint32_t>{};
  if (d.visibilityMethod == AtlasVisibilityMethod::Compute) return d.visibilityCompute(cameras, width, height);
  return d.visibilityHardware(cameras, width, height);
}

std::vector<uint32_t> AtlasShading::Impl::visibilityHardware(std::span<const Camera> cameras, uint32_t width,
                                                             uint32_t height) {
  Impl& d = *this;
  d.ensureDepth(width, height);

  // Instances by pass: opaque (prepass), MASK (prepass with the cutoff), BLEND (marking only).
  std::vector<uint32_t> opaque, mask, blend;
  for (uint32_t i = 0; i < d.instances.size(); ++i) {
    AlphaMode mode = d.sceneMaterials[d.instanceMaterial(i)].alphaMode;
    (mode == AlphaMode::Blend ? blend : mode == AlphaMode::Mask ? mask : opaque).push_back(i);
  }

  d.submitTimed("visibility", [&](VkCommandBuffer cmd) {
    // The cleared flags reach the marking fragments and, for patches none marks, the copy out.
    vkCmdFillBuffer(cmd, d.flags.handle(), 0, VK_WHOLE_SIZE, 0);
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COPY_BIT,
                     VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT | VK_ACCESS_2_TRANSFER_READ_BIT);
    sio::AtlasVisibilityPush push{};
    push.instanceAddress = d.instanceBuffer.address();
    push.firstTriangleAddress = d.firstTriangleBuffer.address();
    push.patchOfTriangleAddress = d.patchOfTriangleBuffer.address();
    push.flagsAddress = d.flags.address();
    push.materialAddress = d.materials.address();
    auto draw = [&](uint32_t instance) {
      const Instance& inst = d.instances[instance];
      const AtlasMeshRange& m = d.meshes[inst.mesh];
      push.materialIndex = m.material;
      vkCmdPushConstants(cmd, d.visibilityLayout, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                         sizeof(push), &push);
      // As the forward renderer: single-sided back faces are culled, mirrored instances flip the winding.
      vkCmdSetCullMode(cmd, d.sceneMaterials[m.material].doubleSided ? VK_CULL_MODE_NONE : VK_CULL_MODE_BACK_BIT);
      vkCmdSetFrontFace(cmd, isMirrored(inst.transform) ? VK_FRONT_FACE_CLOCKWISE : VK_FRONT_FACE_COUNTER_CLOCKWISE);
      // firstInstance = the instance: gl_InstanceIndex finds its transform and first triangle.
      vkCmdDrawIndexed(cmd, m.indexCount, 1, m.firstIndex, int32_t(m.firstVertex), instance);
    };
    auto pass = [&](VkPipeline pipeline, const std::vector<uint32_t>& list) {
      if (list.empty()) return;
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
      for (uint32_t i : list) draw(i);
    };
    for (const Camera& camera : cameras) {
      push.viewProj = viewFrame(withClipPlanes(camera, d.worldBounds), width, height).viewProj;
      // The previous camera's depth tests finish before this one clears the target.
      cmdImageBarrier(cmd,
                      {d.depth.handle(), VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
                       VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
                       VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
                       VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_IMAGE_ASPECT_DEPTH_BIT});
      VkRenderingAttachmentInfo depthAtt{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
      depthAtt.imageView = d.depth.view();
      depthAtt.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
      depthAtt.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
      depthAtt.storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
      depthAtt.clearValue.depthStencil = {0.0f, 0}; // reverse-Z: far is 0
      VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
      ri.renderArea = {{0, 0}, {width, height}};
      ri.layerCount = 1;
      ri.pDepthAttachment = &depthAtt;
      vkCmdBeginRendering(cmd, &ri);
      cmdSetFullViewport(cmd, width, height);
      VkDeviceSize zero = 0;
      VkBuffer vb = d.vertices.handle();
      vkCmdBindVertexBuffers(cmd, 0, 1, &vb, &zero);
      vkCmdBindIndexBuffer(cmd, d.indices.handle(), 0, VK_INDEX_TYPE_UINT32);
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, d.visibilityLayout, 0, 1, &d.descriptors.set, 0,
                              nullptr);
      // Depth and fragment tests run in primitive order within the pass: the marking draws see
      // the finished prepass depth.
      pass(d.prepassOpaque, opaque);
      pass(d.prepassMask, mask);
      std::vector<uint32_t> solid = opaque;
      solid.insert(solid.end(), mask.begin(), mask.end());
      pass(d.markEqual, solid);
      pass(d.markInFront, blend);
      vkCmdEndRendering(cmd);
    }
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
    VkBufferCopy region{0, 0, VkDeviceSize(d.patchCount) * 4};
    vkCmdCopyBuffer(cmd, d.flags.handle(), d.flagsReadback.handle(), 1, &region);
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                     VK_ACCESS_2_HOST_READ_BIT);
  });
  std::vector<uint32_t> marked(d.patchCount);
  std::memcpy(marked.data(), d.flagsReadback.mapped(), marked.size() * 4);
  std::vector<uint32_t> visible;
  for (uint32_t p = 0; p < d.patchCount; ++p)
    if (marked[p]) visible.push_back(p);
  return visible;
}

} // namespace mirage::render
