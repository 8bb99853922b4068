// RenderConfig's ranges, checked once for every caller (CLI, viewer): the messages name the flag.
#include "mirage/runtime/config.h"

namespace mirage::runtime {

Status validate(const RenderConfig& c) {
  if (!(c.tauPixels > 0.0f) || c.tauPixels > 1e6f) return Error{"--tau must be a positive number of pixels"};
  if (!(c.hybridThreshold >= 0.0f) || c.hybridThreshold > 1e6f)
    return Error{"--hybrid-threshold must be a number of pixels in 0..1e6"};
  if (!(c.blendQueuePixels >= 0.0f))
    return Error{"--blend-queue-pixels must be a number of pixels, 0 or more (inf: off)"};
  if (c.oitNodesPerPixel && (*c.oitNodesPerPixel < 1 || *c.oitNodesPerPixel > 64))
    return Error{"--oit-nodes-per-pixel must be in 1..64"};
  if (!(c.foveaGaze.x >= 0.0f && c.foveaGaze.x <= 1.0f && c.foveaGaze.y >= 0.0f && c.foveaGaze.y <= 1.0f))
    return Error{"--fovea must be X,Y in 0..1 (normalized screen coordinates)"};
  if (!(c.foveaRadiusDegrees >= 0.0f && c.foveaRadiusDegrees <= 90.0f))
    return Error{"--fovea-radius must be in 0..90 degrees"};
  if (!(c.surfelSize >= 0.5f && c.surfelSize <= 16.0f)) return Error{"--surfel-size must be in 0.5..16 pixels"};
  return Ok{};
}

} // namespace mirage::runtime
