// The 'SURF' chunk payload (versions 1 and 2): decoding must reject what it cannot represent (NaN
// radii, a non-finite box), and what it accepts must encode and decode again to the same bytes.
#include <cmath>

#include "fuzz_support.h"
#include "mirage/surfels/surfel_io.h"

using namespace mirage;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Result<surfels::MeshSurfels> s = surfels::decodeSurfelChunkWithMesh(std::span(data, size), "in.mrg");
  if (!s) {
    fuzz::checkOneLine(s.error());
    return 0;
  }
  const surfels::SurfelCloud& c = s->cloud;
  for (int i = 0; i < 3; ++i)
    fuzz::check(std::isfinite(c.box.min[i]) && std::isfinite(c.box.max[i]), "decoded SURF box is not finite");
  for (float r : c.radii) fuzz::check(r >= 0.0f, "decoded SURF radius is negative or NaN");
  std::vector<uint8_t> bytes = surfels::encodeSurfelChunk(s->cloud, s->mesh);
  Result<surfels::MeshSurfels> back = surfels::decodeSurfelChunkWithMesh(bytes, "again.mrg");
  if (!back) fuzz::fail("a decoded SURF chunk re-encodes to bytes the decoder rejects: " + back.error().message);
  fuzz::check(back->mesh == s->mesh && surfels::encodeSurfelChunk(back->cloud, back->mesh) == bytes,
              "SURF round trip changes the bytes");
  return 0;
}
