// Real assets from ../shared/data rendered headless with validation on: every model imports,
// renders with the auto camera, covers a sensible part of the frame, and the validation layer stays
// silent. (References for these cannot be committed: the data's licences forbid copies in the repo.)
#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/io/import.h"
#include "mirage/render/forward_renderer.h"
#include "test_support.h"

using namespace mirage;
using namespace mirage::render;

namespace {

double coverage(const ImageRGBA8& img) {
  size_t covered = 0;
  for (size_t i = 0; i < img.pixels.size(); i += 4)
    covered += img.pixels[i] > 2 || img.pixels[i + 1] > 2 || img.pixels[i + 2] > 2;
  return double(covered) / double(img.width * img.height);
}

} // namespace

class RealData : public test::GpuTest, public ::testing::WithParamInterface<const char*> {};

TEST_P(RealData, RendersWithAutoCamera) {
  MIRAGE_REQUIRE_DATA(path, GetParam());
  auto scene = io::importScene(path);
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  auto renderer = ForwardRenderer::create(context(), *scene);
  ASSERT_TRUE(renderer.ok());
  RenderSettings s;
  s.width = 200;
  s.height = 150;
  s.background = {0, 0, 0, 1};
  s.camera = autoCamera(scene->worldBounds(), 200.0f / 150.0f);
  auto out = renderer.value()->render(s);
  ASSERT_TRUE(out.ok());
  double c = coverage(out->srgb);
  EXPECT_GT(c, 0.05) << GetParam() << " covers too little of the frame";
  EXPECT_LE(out->stats.trianglesSubmitted, scene->instancedTriangleCount());
}

INSTANTIATE_TEST_SUITE_P(
    SharedData, RealData,
    ::testing::Values("khronos-damaged-helmet/DamagedHelmet.glb", "khronos-flight-helmet/glTF/FlightHelmet.gltf",
                      "khronos-alpha-blend-mode-test/glTF/AlphaBlendModeTest.gltf", "khronos-suzanne/glTF/Suzanne.gltf",
                      "dabrovic-sponza/gltf/sponza.gltf", "dream-apartment/dream-apartment.meshopt.glb",
                      "stanford-bunny/bun_zipper.ply", "cyberware-horse/horse.ply", "openarena-maps/obj/oasago2.obj"),
    [](const auto& param) {
      std::string n = param.param;
      n = n.substr(0, n.find('/'));
      for (char& ch : n)
        if (!isalnum(static_cast<unsigned char>(ch))) ch = '_';
      return n;
    });
