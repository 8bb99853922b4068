// The 'CDAG' chunk payload. What decodeDag accepts is used without further checks by the
// renderers, the verifier and cut selection, so every index must be in range; the harness checks
// that, runs those CPU consumers, and re-encodes the DAG (the result must decode again).
#include <cmath>

#include "fuzz_support.h"
#include "mirage/lod/dag_codec.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/lod/verify.h"

using namespace mirage;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Result<lod::ClusterDag> dag = lod::decodeDag(std::span(data, size), "in.mrg");
  if (!dag) {
    fuzz::checkOneLine(dag.error());
    return 0;
  }
  fuzz::checkDag(*dag);
  Mesh level0 = lod::levelZeroMesh(*dag);
  for (float threshold : {0.0f, 1e-3f, 1.0f, INFINITY}) {
    std::vector<uint32_t> cut = lod::selectCut(*dag, threshold);
    Mesh m = lod::cutMesh(*dag, cut);
    (void)m;
  }
  Status verified = lod::verifyDag(*dag);
  if (!verified) fuzz::checkOneLine(verified.error());

  std::vector<uint8_t> again = lod::encodeDag(*dag);
  Result<lod::ClusterDag> back = lod::decodeDag(again, "again.mrg");
  if (!back) fuzz::fail("a decoded DAG re-encodes to bytes decodeDag rejects: " + back.error().message);
  return 0;
}
