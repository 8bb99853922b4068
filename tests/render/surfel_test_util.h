#pragma once
// The object of the surfel and mixed renderer tests: a generated blob and its surfel cloud (in the
// exact CPU farthest-point order, which the GPU sampler approximates), made once per process, its
// copies placed as surfels and as LOD meshes, and views of it at a chosen multiple of the distance
// where the cluster renderer switches from mesh to surfels.
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "gpu_test.h"
#include "mirage/core/scene.h"
#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/camera.h"
#include "mirage/render/surfel_renderer.h"
#include "mirage/shaderio/lod_error.h"
#include "mirage/surfels/capture.h"
#include "mirage/surfels/reference.h"

namespace mirage::test {

struct SurfelBlob {
  Scene scene;                // gen:blob, one mesh
  surfels::SurfelCloud cloud; // of that mesh

  // The sphere around the cloud's box (centre, radius).
  glm::vec4 sphere() const { return glm::vec4(cloud.box.center(), 0.5f * glm::length(cloud.box.extent())); }

  // The distance from the camera where the cluster renderer draws the cloud instead of the mesh,
  // for `pixelScale` (shaderio::projectionScale) and surfels `surfelSize` pixels across.
  float switchDistance(float pixelScale, float surfelSize) const {
    float P = float(cloud.referenceCount) * cloud.referenceMeanSpacing * cloud.referenceMeanSpacing;
    return render::surfelSwitchDistance(P, uint32_t(cloud.size()), pixelScale, surfelSize);
  }

  // The cloud placed at each of `transforms`; when `linked`, placement i is mesh instance i of a
  // mixed scene (placedAsset's instance i).
  render::SurfelScene placed(const std::vector<glm::mat4>& transforms, bool linked) const {
    render::SurfelScene s;
    s.clouds.push_back({&cloud, scene.materials[scene.meshes[0].material]});
    for (uint32_t i = 0; i < transforms.size(); ++i) s.instances.push_back({0, transforms[i], linked ? i : UINT32_MAX});
    return s;
  }
};

// gen:blob with `subdivisions`, captured at `resolution`² × 16 views, `count` surfels.
inline SurfelBlob makeSurfelBlob(uint32_t subdivisions, uint32_t resolution, uint32_t count) {
  SurfelBlob b;
  b.scene = io::generateScene("blob", 1, subdivisions).value();
  surfels::CaptureConfig config;
  config.resolution = resolution;
  surfels::GBufferTexels texels = surfels::captureGBuffer(gpuContext(), b.scene, config).value().texels;
  b.cloud = surfels::buildSurfelCloud(texels, surfels::farthestPointReference(texels, count));
  return b;
}

// blob:5 (20 480 triangles) at 128², 20 000 surfels (~1 s on lavapipe), once per process.
inline const SurfelBlob& denseSurfelBlob() {
  static const SurfelBlob b = makeSurfelBlob(5, 128, 20000);
  return b;
}

// blob:4 at 64², 6000 surfels, once per process.
inline const SurfelBlob& smallSurfelBlob() {
  static const SurfelBlob b = makeSurfelBlob(4, 64, 6000);
  return b;
}

// `asset` with its instances replaced by copies of mesh 0 at `transforms`.
inline lod::LodAsset placedAsset(lod::LodAsset asset, const std::vector<glm::mat4>& transforms) {
  asset.scene.instances.clear();
  for (const glm::mat4& t : transforms) asset.scene.instances.push_back({0, t});
  return asset;
}

// The auto view's direction towards the cloud's sphere, the eye where the reference depth (eye to
// the sphere's nearest point) is `depthFactor` × the switch distance for an image `height` pixels
// high and surfels `surfelSize` pixels across.
inline render::Camera cameraAtSwitchDepth(const SurfelBlob& blob, float depthFactor, float height, float surfelSize) {
  render::Camera c = render::autoCamera(blob.scene.worldBounds(), 1.0f);
  float d = blob.switchDistance(shaderio::projectionScale(c.projection(1.0f)[1][1], height), surfelSize);
  glm::vec4 s = blob.sphere();
  c.target = glm::vec3(s);
  c.eye = c.target + glm::normalize(c.eye - c.target) * (s.w + depthFactor * d);
  c.znear = c.zfar = 0.0f; // derived again for the new eye
  return c;
}

} // namespace mirage::test
