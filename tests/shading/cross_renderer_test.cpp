// One material include for every renderer: a material file's Blinn-Phong material applied to a
// baked asset looks the same through the cluster-LOD renderer (visibility buffer + resolve) as
// through the forward renderer of its level-0 meshes.
#include <cstdio>

#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/core/image_metrics.h"
#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/camera.h"
#include "mirage/render/cluster_renderer.h"
#include "mirage/render/forward_renderer.h"
#include "mirage/shading/material_file.h"

using namespace mirage;
using namespace mirage::render;
using mirage::test::GpuTest;

class MaterialCrossRenderer : public GpuTest {};

TEST_F(MaterialCrossRenderer, ClusterLodMatchesForward) {
  io::BlobOptions o;
  o.subdivisions = 3;
  auto baked = lod::bakeLodAsset(io::generateBlob(o), lod::BuildConfig{});
  ASSERT_TRUE(baked.ok()) << baked.error().message;
  lod::LodAsset asset = std::move(*baked);
  auto file = shading::parseMaterialFile(R"([[material]]
name = "glossy"
model = "blinn-phong"
albedo = [0.7, 0.35, 0.1]
specular = [0.5, 0.5, 0.5]
glossiness = 0.4
[[assign]]
mesh = "*"
use = "glossy"
)",
                                         "cross.toml", {});
  ASSERT_TRUE(file.ok()) << file.error().message;
  ASSERT_TRUE(shading::applyMaterials(asset.scene, *file).ok());

  Scene reference = lod::levelZeroScene(asset);
  ClusterRenderSettings s;
  s.base.width = s.base.height = 96;
  s.base.camera = autoCamera(reference.worldBounds(), 1.0f);
  s.base.background = {0, 0, 0, 1};
  s.tauPixels = 0.001f; // full resolution: the same triangles as the forward renderer
  auto forward = ForwardRenderer::create(context(), reference);
  ASSERT_TRUE(forward.ok());
  auto a = (*forward)->render(s.base);
  ASSERT_TRUE(a.ok());
  auto cluster = ClusterRenderer::create(context(), asset);
  ASSERT_TRUE(cluster.ok()) << cluster.error().message;
  auto b = (*cluster)->render(s);
  ASSERT_TRUE(b.ok()) << b.error().message;
  double p = psnr(a->srgb, b->image.srgb);
  std::printf("forward vs cluster LOD, Blinn-Phong material: PSNR %.2f dB\n", p);
  EXPECT_GE(p, 50.0);
  // The material did apply: the blob is orange, not the generator's colour.
  const uint8_t* c = a->srgb.at(48, 48);
  EXPECT_GT(c[0], c[2] + 40);
}
