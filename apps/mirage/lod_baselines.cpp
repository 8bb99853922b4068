#include "lod_baselines.h"

#include <algorithm>
#include <cmath>

#include "mirage/lod/verify.h"
#include "mirage/shaderio/lod_error.h"
#include "render_common.h"

namespace mirage::cli {

namespace {

// A discrete LOD chain of one DAG: the cuts at object-space errors 0, e, 2e, 4e, ... (e the
// smallest non-zero error) up to the root, so level k's error is at most threshold[k]. Cuts with
// the triangle count of the previous level are skipped.
struct Chain {
  std::vector<float> thresholds;
  std::vector<Mesh> meshes;
};

Chain buildChain(const lod::ClusterDag& dag) {
  float smallest = INFINITY, largest = 0.0f;
  for (const lod::Cluster& c : dag.clusters)
    if (c.self.error > 0.0f && std::isfinite(c.self.error)) {
      smallest = std::min(smallest, c.self.error);
      largest = std::max(largest, c.self.error);
    }
  Chain chain;
  size_t previousTriangles = SIZE_MAX;
  auto add = [&](float threshold) {
    Mesh m = lod::cutMesh(dag, lod::selectCut(dag, threshold));
    if (m.triangleCount() == previousTriangles) {
      chain.thresholds.back() = threshold; // same mesh, valid up to the larger error
      return;
    }
    previousTriangles = m.triangleCount();
    chain.thresholds.push_back(threshold);
    chain.meshes.push_back(std::move(m));
  };
  add(0.0f);
  if (std::isfinite(smallest))
    for (float t = smallest; t < largest * 2.0f; t *= 2.0f) add(std::min(t, largest));
  return chain;
}

Result<BaselineResult> timeScene(gpu::Context& context, const Scene& scene, const render::RenderSettings& settings,
                                 int frames, const char* name) {
  auto renderer = render::ForwardRenderer::create(context, scene);
  if (!renderer) return renderer.error();
  std::vector<std::vector<gpu::PassTime>> times;
  BaselineResult r;
  r.name = name;
  for (int i = 0; i < frames; ++i) {
    auto out = (*renderer)->render(settings);
    if (!out) return out.error();
    if (i > 0 || frames == 1) times.push_back(out->stats.passTimes);
    r.triangles = out->stats.trianglesSubmitted;
  }
  r.frameMs = frameMilliseconds(medianPassTimes(times));
  return r;
}

} // namespace

Result<std::vector<BaselineResult>> renderLodBaselines(gpu::Context& context, const lod::LodAsset& asset,
                                                       const render::RenderSettings& settings, float tau, int frames) {
  std::vector<Chain> chains;
  for (const lod::ClusterDag& dag : asset.dags) chains.push_back(buildChain(dag));

  // A chain mesh with its source mesh's material and name.
  auto chainMesh = [&](size_t m, size_t level) {
    Mesh mesh = chains[m].meshes[level];
    mesh.material = asset.scene.meshes[m].material;
    mesh.name = asset.scene.meshes[m].name;
    return mesh;
  };
  std::vector<BaselineResult> out;

  // Brute force: level 0 of mesh m is mesh m, so the instances stay as they are. Built, timed and
  // freed before the discrete scene, so only one scene's geometry lives at a time.
  {
    Scene brute = asset.scene;
    brute.meshes.clear();
    for (size_t m = 0; m < chains.size(); ++m) brute.meshes.push_back(chainMesh(m, 0));
    auto r = timeScene(context, brute, settings, frames, "brute-force");
    if (!r) return r.error();
    out.push_back(std::move(*r));
  }

  // Discrete LOD: every chain level, each instance pointing at its level.
  Scene discrete = asset.scene;
  discrete.meshes.clear();
  std::vector<uint32_t> firstMesh;
  for (size_t m = 0; m < chains.size(); ++m) {
    firstMesh.push_back(uint32_t(discrete.meshes.size()));
    for (size_t level = 0; level < chains[m].meshes.size(); ++level) discrete.meshes.push_back(chainMesh(m, level));
  }
  render::Camera camera = render::withClipPlanes(settings.camera, asset.scene.worldBounds());
  float pixelScale = shaderio::projectionScale(camera.projection(1.0f)[1][1], float(settings.height));
  uint32_t chainLevels = chains.empty() ? 0 : uint32_t(chains[0].meshes.size());
  std::vector<uint32_t> usage(chainLevels, 0);
  for (size_t i = 0; i < asset.scene.instances.size(); ++i) {
    const Instance& inst = asset.scene.instances[i];
    const Chain& chain = chains[inst.mesh];
    const Bounds& b = asset.scene.meshes[inst.mesh].bounds;
    float s = maxAxisScale(inst.transform);
    glm::vec3 centre = glm::vec3(inst.transform * glm::vec4(b.center(), 1.0f));
    uint32_t level = 0; // the coarsest level whose error projects within tau (as the cluster selection)
    for (uint32_t k = 1; k < chain.meshes.size(); ++k)
      if (shaderio::projectedSphereError(centre, b.radius(), chain.thresholds[k], s, camera.eye, camera.znear,
                                         pixelScale) <= tau)
        level = k;
    discrete.instances[i].mesh = firstMesh[inst.mesh] + level;
    if (inst.mesh == 0) ++usage[level];
  }
  auto r = timeScene(context, discrete, settings, frames, "discrete-lod");
  if (!r) return r.error();
  r->chainLevels = chainLevels;
  r->usage = std::move(usage);
  out.push_back(std::move(*r));
  return out;
}

} // namespace mirage::cli
