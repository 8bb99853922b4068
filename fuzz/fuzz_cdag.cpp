// The 'CDAG' chunk payload. What decodeDag accepts is used without further checks by the
// renderers, the verifier and cut selection, so every index must be in range; the harness checks
// that, runs those CPU consumers, and re-encodes the DAG (the result must decode again).
#include <cmath>

#include "fuzz_support.h"
#include "mirage/lod/dag_codec.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/lod/verify.h"

using namespace mirage;

namespace {

void checkRanges(const lod::ClusterDag& dag) {
  size_t vertices = dag.vertexPosition.size();
  for (uint32_t p : dag.vertexPosition) fuzz::check(p < dag.positions.size(), "vertex position id out of range");
  fuzz::check(dag.normals.empty() || dag.normals.size() == vertices, "normal count");
  fuzz::check(dag.uv0.empty() || dag.uv0.size() == vertices, "uv count");
  for (const lod::Cluster& c : dag.clusters) {
    fuzz::check(size_t(c.vertexOffset) + c.vertexCount <= dag.clusterVertices.size(), "cluster vertex range");
    fuzz::check((size_t(c.triangleOffset) + c.triangleCount) * 3 <= dag.clusterIndices.size(),
                "cluster triangle range");
    for (size_t i = 0; i < size_t(c.triangleCount) * 3; ++i)
      fuzz::check(dag.clusterIndices[size_t(c.triangleOffset) * 3 + i] < c.vertexCount, "local index out of range");
    for (size_t i = 0; i < c.vertexCount; ++i)
      fuzz::check(dag.clusterVertices[c.vertexOffset + i] < vertices, "cluster vertex id out of range");
    fuzz::check(c.group == lod::kNone || c.group < dag.groups.size(), "cluster group id");
    fuzz::check(c.generatingGroup == lod::kNone || c.generatingGroup < dag.groups.size(), "generating group id");
  }
  for (const lod::Group& g : dag.groups) {
    fuzz::check(size_t(g.childOffset) + g.childCount <= dag.groupChildren.size(), "group child range");
    fuzz::check(size_t(g.parentOffset) + g.parentCount <= dag.groupParents.size(), "group parent range");
  }
  for (uint32_t c : dag.groupChildren) fuzz::check(c < dag.clusters.size(), "group child id");
  for (uint32_t c : dag.groupParents) fuzz::check(c < dag.clusters.size(), "group parent id");
  for (uint32_t c : dag.roots) fuzz::check(c < dag.clusters.size(), "root id");
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Result<lod::ClusterDag> dag = lod::decodeDag(std::span(data, size), "in.mrg");
  if (!dag) {
    fuzz::checkOneLine(dag.error());
    return 0;
  }
  checkRanges(*dag);
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
