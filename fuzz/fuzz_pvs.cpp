// The 'PVS ' chunk payload: per-cell zstd frames, difference cells and their references. What the
// decoder accepts must satisfy PvsData's contract (IDs sorted, unique, below sceneTriangles; valid
// cells) and survive an encode/decode round trip unchanged.
#include "fuzz_support.h"
#include "mirage/visibility/pvs_storage.h"

using namespace mirage;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Result<vis::PvsData> pvs = vis::decodePvs(std::span(data, size), "in.mrg");
  if (!pvs) {
    fuzz::checkOneLine(pvs.error());
    return 0;
  }
  fuzz::check(pvs->cells.size() == pvs->triangles.size(), "one triangle list per cell");
  for (size_t c = 0; c < pvs->cells.size(); ++c) {
    fuzz::check(bool(vis::validateCell(pvs->cells[c], "cell")), "decoded cell fails validateCell");
    const std::vector<uint32_t>& t = pvs->triangles[c];
    for (size_t i = 0; i < t.size(); ++i) {
      fuzz::check(t[i] < pvs->sceneTriangles, "triangle ID out of range");
      fuzz::check(i == 0 || t[i - 1] < t[i], "triangle IDs not sorted and unique");
    }
  }
  vis::PvsEncodeOptions fast;
  fast.zstdLevel = 1;
  std::vector<uint8_t> bytes = vis::encodePvs(*pvs, fast);
  Result<vis::PvsData> back = vis::decodePvs(bytes, "again.mrg");
  if (!back) fuzz::fail("a decoded PVS re-encodes to bytes the decoder rejects: " + back.error().message);
  fuzz::check(back->sceneTriangles == pvs->sceneTriangles && back->triangles == pvs->triangles,
              "PVS round trip changes the sets");
  return 0;
}
