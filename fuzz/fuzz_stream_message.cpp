// One stream message (docs/stream.md, "Protocol"), as a WebSocket binary frame carries it. What the
// decoder accepts must re-encode to the same bytes (the format has one encoding per message; a zstd
// patch section is the exception: any zstd frame of the same content decodes alike, so there the
// re-encoded message must decode to an equal one) and decode again to an equal message; a rejection
// is one line. Decoded patch entries hold what the format allows (1..3 triangles, grid coordinates,
// block-only entries without alpha or positions, increasing ids); decoded particle looks and particles
// too (blocks inside the atlas, each look used, a positive grid step, finite sizes). The client order rules take any
// decoded message without failing on anything but their documented errors.
#include <cmath>
#include <set>

#include "fuzz_support.h"
#include "mirage/stream/protocol.h"

using namespace mirage;
using namespace mirage::stream;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::span<const uint8_t> bytes(data, size);
  DecodeLimits limits;
  limits.maxMessageBytes = 1u << 20;
  limits.maxPatchesPerFrame = 4096;
  Result<Message> message = decodeMessage(bytes, limits, "fuzz");
  if (!message) {
    fuzz::checkOneLine(message.error());
    return 0;
  }
  std::vector<uint8_t> again = encodeMessage(*message);
  const Frame* frame = std::get_if<Frame>(&*message);
  if (!frame || (frame->patchCodec == PatchCodec::Raw && frame->particleCodec == PatchCodec::Raw))
    fuzz::check(again.size() == size && std::equal(again.begin(), again.end(), data),
                "a decoded message re-encodes to other bytes");
  Result<Message> back = decodeMessage(again, limits, "fuzz");
  if (!back) fuzz::fail("a decoded message re-encodes to bytes the decoder rejects: " + back.error().message);
  fuzz::check(*back == *message, "message round trip changes it");
  if (frame) {
    for (size_t i = 0; i < frame->updated.size(); ++i) {
      const PatchUpdate& p = frame->updated[i];
      fuzz::check(p.triangleCount >= 1 && p.triangleCount <= 3, "decoded patch with triangleCount outside 1..3");
      fuzz::check(i == 0 || p.id > frame->updated[i - 1].id, "decoded patch ids not increasing");
      for (const glm::uvec3& q : p.positions)
        fuzz::check(q.x <= kPositionGridMax && q.y <= kPositionGridMax && q.z <= kPositionGridMax,
                    "decoded position outside the grid");
      if (!p.geometry)
        fuzz::check(p.alpha == stream::AlphaMode::Opaque && p.positions == std::array<glm::uvec3, 5>{},
                    "decoded block-only entry with alpha or positions");
    }
    for (size_t i = 1; i < frame->removed.size(); ++i)
      fuzz::check(frame->removed[i] > frame->removed[i - 1], "decoded removed ids not increasing");
    for (size_t i = 1; i < frame->colours.size(); ++i)
      fuzz::check(frame->colours[i].id > frame->colours[i - 1].id, "decoded colour ids not increasing");
    std::set<uint32_t> usedLooks;
    for (const StreamParticle& p : frame->particles) usedLooks.insert(p.look);
    for (size_t i = 0; i < frame->looks.size(); ++i) {
      const ParticleLook& l = frame->looks[i];
      fuzz::check(i == 0 || l.id > frame->looks[i - 1].id, "decoded look ids not increasing");
      fuzz::check(l.blockLog2 == kColourOnlyBlock ||
                      (l.blockLog2 >= 1 && l.blockLog2 <= 7 && l.blockX + (1u << l.blockLog2) <= limits.maxAtlasSide &&
                       l.blockY + (1u << l.blockLog2) <= limits.maxAtlasSide),
                  "decoded look block outside 1..7 or the atlas");
      fuzz::check(usedLooks.count(l.id) == 1, "decoded look no particle uses");
    }
    if (!frame->particles.empty())
      fuzz::check(std::isfinite(frame->particleStep) && frame->particleStep > 0.0f, "decoded particle step not > 0");
    for (const StreamParticle& p : frame->particles)
      fuzz::check(std::isfinite(particleSize(p.size)) && particleSize(p.size) >= 0.0f,
                  "decoded particle size not finite or negative");
  }
  ClientMessageOrder order;
  Status first = acceptClientMessage(order, *message, "fuzz");
  if (!first) fuzz::checkOneLine(first.error());
  return 0;
}
