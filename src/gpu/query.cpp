#include "mirage/gpu/query.h"

#include "mirage/gpu/context.h"

namespace mirage::gpu {

double passMilliseconds(const std::vector<PassTime>& times, std::string_view name, double missing) {
  for (const PassTime& t : times)
    if (t.name == name) return t.milliseconds;
  return missing;
}

GpuTimer::GpuTimer(Context& context, uint32_t maxPasses)
    : context_(context), maxPasses_(maxPasses), supported_(context.caps().timestamps) {
  if (!supported_) return;
  VkQueryPoolCreateInfo ci{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
  ci.queryType = VK_QUERY_TYPE_TIMESTAMP;
  ci.queryCount = maxPasses * 2;
  VkQueryPool pool;
  MIRAGE_VK_CHECK(vkCreateQueryPool(context.device(), &ci, nullptr, &pool));
  pool_ = Unique<VkQueryPool>(context.device(), pool);
}

void GpuTimer::cmdReset(VkCommandBuffer cmd) {
  names_.clear();
  if (supported_) vkCmdResetQueryPool(cmd, pool_, 0, maxPasses_ * 2);
}

uint32_t GpuTimer::cmdBegin(VkCommandBuffer cmd, const std::string& name, VkPipelineStageFlags2 stage) {
  uint32_t slot = uint32_t(names_.size());
  if (!supported_ || slot >= maxPasses_) return UINT32_MAX;
  names_.push_back(name);
  vkCmdWriteTimestamp2(cmd, stage, pool_, slot * 2);
  return slot;
}

void GpuTimer::cmdEnd(VkCommandBuffer cmd, uint32_t slot, VkPipelineStageFlags2 stage) {
  if (slot == UINT32_MAX) return;
  vkCmdWriteTimestamp2(cmd, stage, pool_, slot * 2 + 1);
}

std::vector<PassTime> GpuTimer::read() const {
  std::vector<PassTime> out;
  if (!supported_ || names_.empty()) return out;
  std::vector<uint64_t> ticks(names_.size() * 2);
  MIRAGE_VK_CHECK(vkGetQueryPoolResults(context_.device(), pool_, 0, uint32_t(ticks.size()), ticks.size() * 8,
                                        ticks.data(), 8, VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
  double period = context_.caps().timestampPeriodNs;
  // An end before its begin reads as 0 rather than wrapping around: lavapipe resolves a timestamp
  // when its rasterizer runs the binned scene, so a pass holding only copies after a rendering
  // (stereo's layer-copy) can end "before" it began.
  for (size_t i = 0; i < names_.size(); ++i)
    out.push_back(
        {names_[i], ticks[2 * i + 1] >= ticks[2 * i] ? double(ticks[2 * i + 1] - ticks[2 * i]) * period * 1e-6 : 0.0});
  return out;
}

PipelineStatsQuery::PipelineStatsQuery(Context& context) : context_(context) {
  if (!context.caps().pipelineStatistics) return;
  VkQueryPoolCreateInfo ci{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
  ci.queryType = VK_QUERY_TYPE_PIPELINE_STATISTICS;
  ci.queryCount = 1;
  ci.pipelineStatistics = VK_QUERY_PIPELINE_STATISTIC_INPUT_ASSEMBLY_PRIMITIVES_BIT |
                          VK_QUERY_PIPELINE_STATISTIC_VERTEX_SHADER_INVOCATIONS_BIT |
                          VK_QUERY_PIPELINE_STATISTIC_CLIPPING_PRIMITIVES_BIT |
                          VK_QUERY_PIPELINE_STATISTIC_FRAGMENT_SHADER_INVOCATIONS_BIT |
                          VK_QUERY_PIPELINE_STATISTIC_COMPUTE_SHADER_INVOCATIONS_BIT;
  VkQueryPool pool;
  MIRAGE_VK_CHECK(vkCreateQueryPool(context.device(), &ci, nullptr, &pool));
  pool_ = Unique<VkQueryPool>(context.device(), pool);
}

void PipelineStatsQuery::cmdReset(VkCommandBuffer cmd) {
  if (pool_) vkCmdResetQueryPool(cmd, pool_, 0, 1);
}
void PipelineStatsQuery::cmdBegin(VkCommandBuffer cmd) {
  if (pool_) vkCmdBeginQuery(cmd, pool_, 0, 0);
}
void PipelineStatsQuery::cmdEnd(VkCommandBuffer cmd) {
  if (pool_) vkCmdEndQuery(cmd, pool_, 0);
}

PipelineStatistics PipelineStatsQuery::read() const {
  PipelineStatistics s;
  if (!pool_) return s;
  uint64_t v[5] = {};
  MIRAGE_VK_CHECK(vkGetQueryPoolResults(context_.device(), pool_, 0, 1, sizeof(v), v, 8,
                                        VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT));
  // Results come in bit order of the enabled statistics.
  s.inputPrimitives = v[0];
  s.vertexInvocations = v[1];
  s.clippingPrimitives = v[2];
  s.fragmentInvocations = v[3];
  s.computeInvocations = v[4];
  return s;
}

} // namespace mirage::gpu
