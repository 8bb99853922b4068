// Particle billboards in the cluster-LOD renderer (docs/render.md, "Particles"): drawn after the
// blend rasters over the read-only opaque depth, each fragment appended to the transparency lists
// with its shaded colour beside its node and its id tagged MIRAGE_OIT_COLOR_ID_TAG, so the
// composite sorts particles and BLEND clusters together per pixel.
#include "cluster_impl.h"
#include "mirage/gpu/commands.h"
#include "mirage/render/particle_draw.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

// A frame with particles. The first: the lists from then on carry a colour per node (and exist
// without BLEND materials), with the larger default pool (ensureOitPool, which the caller runs
// next; the replaced pool lives until the frames in flight that use it completed). Per slot, the
// OitLists the billboards append through. With the splat, its sums at the target's size
// (recreated with the targets, or when their format changes).
void ClusterRenderer::Impl::prepareParticles(ParticleDraw& particles) {
  if (particles.splats(OitMode::LinkedList)) {
    uint64_t bytes = particles.splatBytes(uint64_t(colorWidth) * height);
    if (!splatAccum || splatAccum.size() != bytes) {
      retired.retire(std::move(splatAccum), inFlightSlots());
      splatAccum = createBuffer(ctx, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                MemoryUsage::GpuOnly, "particle splat sums");
    }
  }
  if (particleOit) return;
  particleOit = true;
  if (!oitHeads) createOitHeads();
  oitNodesPerPixel = 0; // ensureOitPool makes the pool again, with colours
  for (Buffer& lists : particleLists)
    lists = createBuffer(ctx, sizeof(sio::OitLists), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::Upload,
                         "particle lists");
  // Particles alone leave only stored colours: the composite without shading (cmdTransparency).
  createCompositePipeline(/*stored=*/!hasBlend());
}

// The splat's view of this frame: the eyes' frames (p: the mono frame, or the left eye's in
// stereo), the side-by-side depth and colour, the sums.
ParticleSplatTarget ClusterRenderer::Impl::splatTarget(const sio::ClusterPush& p) {
  ParticleSplatTarget t;
  t.slot = currentSlot;
  t.eyes = plans[currentSlot].stereo ? 2 : 1;
  for (uint32_t e = 0; e < t.eyes; ++e) t.frames[e] = p.frameAddress + e * kFrameStride;
  t.eyeWidth = width;
  t.height = height;
  t.depth = depth.view();
  t.color = color.view();
  t.accumulators = &splatAccum;
  t.timer = &timer();
  return t;
}

// After the composite: the splatted particles' sums over the colour (ParticleDraw::cmdSplatResolve
// orders it after the composite's writes).
void ClusterRenderer::Impl::cmdSplatResolve(VkCommandBuffer cmd, const sio::ClusterPush& p, ParticleDraw& particles) {
  uint32_t slot = timer().cmdBegin(cmd, "splat-resolve", kCS);
  particles.cmdSplatResolve(cmd, splatTarget(p));
  timer().cmdEnd(cmd, slot, kCS);
}

// The splat of the small particles, then the billboards of the rest (or of every particle), per eye
// with that eye's frame, viewport and scissor (stereo), over the opaque depth as a read-only
// attachment tested GREATER before the fragment shader runs.
// barriers: the depth prepared by cmdBlendDepth (DEPTH_READ_ONLY_OPTIMAL, its writes visible to
// the depth tests and, since the raster, to compute shaders), the heads and sums zeroed and the
// particles' draw arguments written (cmdPrepare). The lists' writes are made visible by the
// caller's next phase barrier.
void ClusterRenderer::Impl::cmdParticles(VkCommandBuffer cmd, const sio::ClusterPush& p, ParticleDraw& particles) {
  if (plans[currentSlot].splat) { // the small ones into the sums (zeroed at the frame start), the rest listed
    uint32_t splat = timer().cmdBegin(cmd, "splat", kCS);
    particles.cmdSplat(cmd, splatTarget(p));
    timer().cmdEnd(cmd, splat, kCS);
    // The splat bound its own sets: the renderer's back for the composite.
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &descriptors[currentSlot].set, 0,
                            nullptr);
  }
  uint32_t slot = timer().cmdBegin(cmd, "particles");
  cmdBeginOverOpaqueDepth(cmd);
  uint32_t eyes = plans[currentSlot].stereo ? 2 : 1;
  for (uint32_t e = 0; e < eyes; ++e) {
    if (eyes == 2) {
      VkViewport vp{float(e * width), 0.0f, float(width), float(height), 0.0f, 1.0f};
      VkRect2D scissor{{int32_t(e * width), 0}, {width, height}};
      vkCmdSetViewport(cmd, 0, 1, &vp);
      vkCmdSetScissor(cmd, 0, 1, &scissor);
    }
    // The eye's ClusterFrame starts with its ViewFrame, which is all the billboards read.
    particles.cmdDraw(cmd, OitMode::LinkedList, p.frameAddress + e * kFrameStride,
                      particleLists[currentSlot].address());
  }
  vkCmdEndRendering(cmd);
  timer().cmdEnd(cmd, slot);
}

} // namespace mirage::render
