// A lossless atlas frame (stream/tile_codec.h), as a client receives it from the network: applied
// on a fresh decoder (only keyframes can pass) and on one holding frame 0 of primedAtlas (deltas
// against it can). Rejections must be one line and leave the image untouched; an accepted frame
// must give a width x height image that re-encodes and decodes to itself.
#include "fuzz_support.h"
#include "mirage/stream/tile_codec.h"

using namespace mirage;

namespace {

// The 64 x 48 image the primed decoder holds (fuzz/regressions/tile_delta holds deltas against it).
std::vector<uint8_t> primedAtlas() {
  std::vector<uint8_t> image(64 * 48 * 4);
  for (size_t i = 0; i < image.size(); ++i) image[i] = uint8_t(i * 7 + i / 256);
  return image;
}

void apply(stream::TileDeltaDecoder& decoder, std::span<const uint8_t> payload) {
  std::vector<uint8_t> before = decoder.image();
  Status status = decoder.decode(payload);
  if (!status) {
    fuzz::checkOneLine(status.error());
    fuzz::check(decoder.image() == before, "a rejected frame changed the image");
    return;
  }
  fuzz::check(decoder.image().size() == size_t(decoder.width()) * decoder.height() * 4, "image size");
  stream::TileDeltaEncoder encoder(decoder.width(), decoder.height(), 1);
  Result<std::vector<uint8_t>> again = encoder.encode(decoder.image());
  if (!again) fuzz::fail("a decoded image does not re-encode: " + again.error().message);
  stream::TileDeltaDecoder fresh;
  Status back = fresh.decode(*again);
  if (!back) fuzz::fail("a re-encoded keyframe is rejected: " + back.error().message);
  fuzz::check(fresh.image() == decoder.image(), "tile codec round trip changes the image");
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::span<const uint8_t> payload(data, size);
  stream::TileDeltaDecoder fresh;
  apply(fresh, payload);

  static const std::vector<uint8_t> keyframe = [] {
    stream::TileDeltaEncoder encoder(64, 48);
    return std::move(encoder.encode(primedAtlas())).value();
  }();
  stream::TileDeltaDecoder primed;
  fuzz::check(bool(primed.decode(keyframe)), "the primed keyframe decodes");
  apply(primed, payload);
  return 0;
}
