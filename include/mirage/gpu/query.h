#pragma once
// GPU timing from timestamp queries (per-pass times) and pipeline-statistics queries.
#include <string>
#include <string_view>
#include <vector>

#include "mirage/gpu/vk.h"

namespace mirage::gpu {

class Context;

struct PassTime {
  std::string name;
  double milliseconds = 0.0;
};
// The time of the pass named `name` (e.g. a renderer's "frame"), or `missing` when none ran.
double passMilliseconds(const std::vector<PassTime>& times, std::string_view name, double missing = 0.0);

// Pairs of timestamps around named passes. Reset with cmdReset at the start of a command buffer,
// then cmdBegin/cmdEnd around each pass; read() after the submission completed.
class GpuTimer {
public:
  GpuTimer(Context& context, uint32_t maxPasses = 32);
  void cmdReset(VkCommandBuffer cmd);
  // Returns a pass slot; passes may nest (a "frame" around the others).
  uint32_t cmdBegin(VkCommandBuffer cmd, const std::string& name,
                    VkPipelineStageFlags2 stage = VK_PIPELINE_STAGE_2_TOP_OF_PIPE_BIT);
  void cmdEnd(VkCommandBuffer cmd, uint32_t slot, VkPipelineStageFlags2 stage = VK_PIPELINE_STAGE_2_BOTTOM_OF_PIPE_BIT);
  std::vector<PassTime> read() const;
  bool supported() const { return supported_; }

private:
  Context& context_;
  Unique<VkQueryPool> pool_;
  std::vector<std::string> names_;
  uint32_t maxPasses_;
  bool supported_;
};

struct PipelineStatistics {
  uint64_t inputPrimitives = 0; // input assembly primitives
  uint64_t vertexInvocations = 0;
  uint64_t clippingPrimitives = 0; // primitives that reached the clipper
  uint64_t fragmentInvocations = 0;
  uint64_t computeInvocations = 0;
};

// One pipeline-statistics query around a range of commands (not inside a render pass boundary
// mismatch: begin and end outside or inside the same pass).
class PipelineStatsQuery {
public:
  explicit PipelineStatsQuery(Context& context);
  bool supported() const { return bool(pool_); }
  void cmdReset(VkCommandBuffer cmd);
  void cmdBegin(VkCommandBuffer cmd);
  void cmdEnd(VkCommandBuffer cmd);
  PipelineStatistics read() const;

private:
  Context& context_;
  Unique<VkQueryPool> pool_;
};

} // namespace mirage::gpu
