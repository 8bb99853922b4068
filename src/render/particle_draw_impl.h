#pragma once
// ParticleDraw's state, shared by its files:
//   particle_draw.cpp  sheets, batches, draw arguments, the billboards
//   particle_sort.cpp  sorted mode: GPU depth sort of the records, gaps between sorted triangles
//   particle_splat.cpp the splat of small particles and its resolve
#include <iterator>
#include <memory>
#include <vector>

#include "mirage/gpu/descriptors.h"
#include "mirage/gpu/pipeline.h"
#include "mirage/gpu/radix_sort.h"
#include "mirage/render/frames_in_flight.h"
#include "mirage/render/particle_draw.h"
#include "mirage/shaderio/particle_draw.h"

namespace mirage::render {

struct ParticleDraw::Impl {
  gpu::Context& ctx;
  std::vector<gpu::Image> sheetImages;
  std::vector<ParticleSheet> sheets; // tiles and flags (images dropped after upload)
  gpu::Unique<VkSampler> sampler;
  gpu::DescriptorSet descriptors;
  gpu::Unique<VkPipelineLayout> layout;
  gpu::Unique<VkPipeline> pipelines[std::size(kOitModeNames)]; // by OitMode (linked lists, weighted, sorted used)
  std::vector<ParticleBatch> batches;
  gpu::Buffer cpuRecords; // setCpuBatches' records
  // Per batch, written by cmdPrepare: its VkDrawIndirectCommand (instanceCount = live records) and
  // its ParticleBatchInfo (the compute passes' and list draws' view of the global numbering).
  gpu::Buffer indirect, batchTable;
  uint32_t batchCapacity = 0;
  uint32_t totalRecords = 0; // record slots over the batches (the global numbering's size)

  ParticleDrawSettings settings;

  // The compute passes' layout (set 0: the sheets, set 1: a frame's depth and colour; the largest
  // push), made with the first of them.
  gpu::Unique<VkPipelineLayout> computeLayout;
  // Sorted mode (particle_sort.cpp), made on first use: the key and gap passes, the keys (uint64
  // per record slot) and their radix sort.
  gpu::Unique<VkPipeline> sortKeysPipeline, sortGapsPipeline;
  gpu::Buffer sortKeys;
  std::unique_ptr<gpu::RadixSort> radix;

  // The splat (particle_splat.cpp), made on first use: its pass and resolve, per frame slot the
  // set naming the target's depth and colour, the billboards' list (global records) and its draw.
  gpu::Unique<VkPipeline> splatPipelines[2], splatResolvePipeline; // [fixed point]
  gpu::Unique<VkSampler> depthSampler;
  gpu::DescriptorSet frameSets[kMaxFramesInFlight];
  gpu::Buffer largeList, largeArgs;
  // Binned (made on first use): count/scatter, scan and tile passes, the bins (sized by the
  // target's tiles), the entries and the count workgroups' tables (sized by the records).
  gpu::Unique<VkPipeline> binPipelines[2], tilePipelines[2], scanPipeline; // [fixed point]
  gpu::Buffer bins, entries, tables;
  uint32_t entryRoom = 0;
  bool fixedPoint = false;    // the last cmdSplat accumulated in fixed point (settings and device)
  bool splatRecorded = false; // cmdSplat ran since cmdPrepare: cmdDraw draws the list

  explicit Impl(gpu::Context& c) : ctx(c) {}
  VkPipeline pipeline(OitMode mode);
  const ParticleSheet& sheetOf(const ParticleBatch& b) const {
    return sheets[std::min<size_t>(b.sheet, sheets.size() - 1)];
  }
  shaderio::ParticleDrawPush drawPush(VkDeviceAddress frame, VkDeviceAddress oitLists) const;
  void cmdBindDraw(VkCommandBuffer cmd, OitMode mode);
  void ensureComputeLayout();
  // A compute pass over the record slots (the sort's and the splat's), `perThread` slots per
  // thread of MIRAGE_PARTICLE_DRAW_GROUP, in rows of workgroups (gpu::dispatchRows); at least one
  // workgroup, which finds no records.
  void cmdDispatchRecords(VkCommandBuffer cmd, uint32_t perThread = 1) const;
  shaderio::ParticleSplatPush splatPush(const ParticleSplatTarget& t) const;
  // The binned splat's passes (count, scan, scatter, tiles) with `push` bound to the compute layout,
  // each timed by `timer` where given.
  void cmdSplatBinned(VkCommandBuffer cmd, shaderio::ParticleSplatPush push, gpu::GpuTimer* timer);
};

} // namespace mirage::render
