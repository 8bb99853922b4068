// One stream message (docs/stream.md, "Protocol"), as a WebSocket binary frame carries it. What the
// decoder accepts must re-encode to the same bytes (the format has one encoding per message) and
// decode again to an equal message; a rejection is one line. The client order rules take any
// decoded message without failing on anything but their documented errors.
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
  fuzz::check(again.size() == size && std::equal(again.begin(), again.end(), data),
              "a decoded message re-encodes to other bytes");
  Result<Message> back = decodeMessage(again, limits, "fuzz");
  if (!back) fuzz::fail("a decoded message re-encodes to bytes the decoder rejects: " + back.error().message);
  fuzz::check(*back == *message, "message round trip changes it");
  if (const Frame* frame = std::get_if<Frame>(&*message)) {
    for (const PatchUpdate& p : frame->updated)
      fuzz::check(p.triangleCount >= 1 && p.triangleCount <= 3, "decoded patch with triangleCount outside 1..3");
  }
  ClientMessageOrder order;
  Status first = acceptClientMessage(order, *message, "fuzz");
  if (!first) fuzz::checkOneLine(first.error());
  return 0;
}
