// The 'SURF' chunk payload (flat versions 1 and 2, blocked version 3): decoding must reject what it
// cannot represent (NaN radii, a non-finite box, damaged blocks), and what it accepts must encode
// and decode again to the same cloud. Every byte prefix of the input goes through the progressive
// decoder (decodeSurfelPrefix), which must agree with the whole decode on the surfels it returns.
#include <cmath>
#include <cstring>

#include "fuzz_support.h"
#include "mirage/asset/format.h"
#include "mirage/surfels/surfel_io.h"

using namespace mirage;

namespace {

bool sameSurfels(const surfels::SurfelCloud& prefix, const surfels::SurfelCloud& whole) {
  // memcmp of empty vectors may get null pointers, which it must not.
  if (prefix.size() > whole.size() || prefix.radii.size() != prefix.size()) return false;
  return prefix.size() == 0 ||
         (std::memcmp(prefix.surfels.data(), whole.surfels.data(), prefix.size() * sizeof(surfels::Surfel)) == 0 &&
          std::memcmp(prefix.radii.data(), whole.radii.data(), prefix.size() * sizeof(float)) == 0);
}

bool isBlockedInput(std::span<const uint8_t> data) {
  uint32_t magic = 0;
  if (data.size() >= 4) std::memcpy(&magic, data.data(), 4);
  return magic == asset::kBlockMagic;
}

// Prefixes: a few lengths spread over the input (every length would make each input quadratic).
void checkPrefixes(std::span<const uint8_t> data, const Result<surfels::MeshSurfels>& whole) {
  size_t step = std::max<size_t>(1, data.size() / 16);
  for (size_t n = 0; n <= data.size(); n += (n < 64 ? 1 : step)) {
    Result<surfels::SurfelPrefix> p = surfels::decodeSurfelPrefix(data.first(n), "in.mrg");
    if (!p) {
      fuzz::check(!(whole && isBlockedInput(data)),
                  "a prefix of a SURF payload that decodes is rejected: " + p.error().message);
      fuzz::checkOneLine(p.error());
      continue;
    }
    const surfels::SurfelCloud& c = p->surfels.cloud;
    fuzz::check(c.size() <= p->total, "SURF prefix holds more surfels than its header");
    fuzz::check(p->complete() ? p->nextBytes == n : p->nextBytes > n, "SURF prefix: nextBytes makes no progress");
    for (float r : c.radii) fuzz::check(r >= 0.0f, "decoded SURF prefix radius is negative or NaN");
    // A prefix of a payload the whole decoder accepts holds exactly the first surfels of that cloud.
    if (whole) fuzz::check(sameSurfels(c, whole->cloud), "SURF prefix is not a prefix of the whole cloud");
    if (n == data.size() && whole && p->haveIndex)
      fuzz::check(p->complete(), "whole SURF payload decodes but its prefix reader stops early");
  }
}

void checkPayload(std::span<const uint8_t> bytes);

} // namespace

// The input as is, and a blocked input again with its checksums resealed (fuzz_support.h), so
// mutations reach the block table checks and the surfel records behind the checksums.
extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::span<const uint8_t> bytes(data, size);
  checkPayload(bytes);
  if (isBlockedInput(bytes)) checkPayload(fuzz::resealBlocks(bytes));
  return 0;
}

namespace {

void checkPayload(std::span<const uint8_t> bytes) {
  Result<surfels::MeshSurfels> s = surfels::decodeSurfelChunkWithMesh(bytes, "in.mrg");
  checkPrefixes(bytes, s);
  if (!s) {
    fuzz::checkOneLine(s.error());
    return;
  }
  const surfels::SurfelCloud& c = s->cloud;
  for (int i = 0; i < 3; ++i)
    fuzz::check(std::isfinite(c.box.min[i]) && std::isfinite(c.box.max[i]), "decoded SURF box is not finite");
  for (float r : c.radii) fuzz::check(r >= 0.0f, "decoded SURF radius is negative or NaN");
  Result<std::vector<uint8_t>> encoded = surfels::encodeSurfelChunk(s->cloud, s->mesh);
  if (!encoded) fuzz::fail("a decoded SURF chunk does not encode: " + encoded.error().message);
  Result<surfels::MeshSurfels> back = surfels::decodeSurfelChunkWithMesh(*encoded, "again.mrg");
  if (!back) fuzz::fail("a decoded SURF chunk re-encodes to bytes the decoder rejects: " + back.error().message);
  fuzz::check(back->mesh == s->mesh && *surfels::encodeSurfelChunk(back->cloud, back->mesh) == *encoded,
              "SURF round trip changes the bytes");
  fuzz::check(sameSurfels(back->cloud, c) && back->cloud.size() == c.size(), "SURF round trip changes the surfels");
  // The flat layout earlier builds wrote decodes to the same cloud.
  Result<surfels::MeshSurfels> flat =
      surfels::decodeSurfelChunkWithMesh(surfels::encodeSurfelChunkFlat(c, s->mesh), "flat.mrg");
  fuzz::check(flat && flat->mesh == s->mesh && flat->cloud.size() == c.size() && sameSurfels(flat->cloud, c),
              "SURF flat round trip changes the surfels");
}

} // namespace
