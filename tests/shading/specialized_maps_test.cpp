// Optional maps specialized (the default: shading.glsl's kMaterialMaps holds only the scene's maps,
// absent ones compile away) shade exactly as the pipeline that decides every map per material
// (MIRAGE_SPECIALIZE_MAPS=0), in the cluster-LOD resolve (docs/shading.md, "Optional maps").
#include <cstdlib>

#include <gtest/gtest.h>

#include "gpu_test.h"
#include "lit_plane.h"
#include "mirage/io/image_io.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/cluster_renderer.h"
#include "test_support.h"

using namespace mirage;
using namespace mirage::render;
using namespace mirage::test;

namespace {

// The cluster renderer's image of `p`, with the resolve specialized or not.
ImageRGBA8 clusterImage(gpu::Context& ctx, const Plane& p, bool specialize) {
  if (!specialize) setenv("MIRAGE_SPECIALIZE_MAPS", "0", 1);
  auto baked = lod::bakeLodAsset(p.scene, lod::BuildConfig{});
  EXPECT_TRUE(baked.ok());
  auto r = ClusterRenderer::create(ctx, *baked);
  unsetenv("MIRAGE_SPECIALIZE_MAPS");
  EXPECT_TRUE(r.ok()) << r.error().message;
  ClusterRenderSettings s;
  s.base = p.settings;
  s.base.lightDirection = {0.3f, 0.2f, 1.0f};
  auto out = r.value()->render(s);
  EXPECT_TRUE(out.ok()) << out.error().message;
  return out.ok() ? out->image.srgb : ImageRGBA8{};
}

} // namespace

class SpecializedMaps : public GpuTest {};

TEST_F(SpecializedMaps, SameImageAsPerMaterialBranches) {
  auto dir = tempDir("specialized_maps");
  ASSERT_TRUE(io::writePng(dir / "red_green.png", ImageRGBA8{2, 1, {255, 0, 0, 255, 0, 255, 0, 255}}).ok());
  ASSERT_TRUE(io::writePng(dir / "bumps.png", ImageRGBA8{2, 1, {200, 128, 230, 255, 60, 128, 230, 255}}).ok());
  const std::string materials[] = {
      "", // no maps: the specialized resolve samples nothing
      "albedo_texture = \"red_green.png\"\n",
      "albedo_texture = \"red_green.png\"\nnormal_texture = \"bumps.png\"\ndetail_albedo_texture = "
      "\"red_green.png\"\ndetail_mask_texture = \"red_green.png\"\n",
  };
  for (const std::string& maps : materials) {
    Plane p;
    applyToml(p.scene,
              "[[material]]\nname = \"m\"\nmodel = \"blinn-phong\"\nspecular = [0.3, 0.3, 0.3]\n" + maps +
                  "[[assign]]\nmesh = \"plane\"\nuse = \"m\"\n[[light]]\nposition = [0.5, 0, 1]\n",
              dir);
    ImageRGBA8 dynamic = clusterImage(context(), p, false), specialized = clusterImage(context(), p, true);
    ASSERT_EQ(dynamic.pixels.size(), specialized.pixels.size());
    EXPECT_EQ(dynamic.pixels, specialized.pixels) << "maps: " << maps;
  }
}
