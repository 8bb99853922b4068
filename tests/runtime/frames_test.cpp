// runtime::Scene frames in flight (docs/runtime.md "Frames in flight"): three frames recorded into
// slots 0..2 before any wait, the eye changing PVS cell between them (the replaced cluster PVS must
// outlive the frames reading it, with no device wait), give the images and counters of three
// sequential render() calls.
#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/runtime/scene.h"
#include "mirage/visibility/pvs_storage.h"
#include "mirage/visibility/ray_backend.h"
#include "test_support.h"

using namespace mirage;
using mirage::test::GpuTest;
namespace fs = std::filesystem;

namespace {

constexpr uint32_t kWidth = 64, kHeight = 48;

class RuntimeFrames : public GpuTest {};

} // namespace

TEST_F(RuntimeFrames, ThreeRecordedFramesMatchSequentialRenders) {
  static_assert(render::kMaxFramesInFlight == 3);
  // A city whose PVS has two cells: cell 0 sees everything, cell 1 only the first instance.
  mirage::Scene city = io::generateScene("city", 1, 1).value();
  fs::path dir = test::tempDir("runtime_frames");
  fs::path mrg = dir / "city.mrg", pvsPath = dir / "pvs.mrg";
  ASSERT_TRUE(lod::saveLodAsset(mrg.string(), lod::bakeLodAsset(city, {}).value()).ok());
  render::Camera base = render::autoCamera(city.worldBounds(), float(kWidth) / float(kHeight));
  glm::vec3 step = glm::normalize(glm::cross(base.target - base.eye, glm::vec3(0, 1, 0))) * 2.0f;
  vis::PvsData pvs;
  pvs.sceneTriangles = city.instancedTriangleCount();
  pvs.cells.resize(2);
  pvs.cells[0].position = base.eye;
  pvs.cells[1].position = base.eye + step;
  std::vector<uint64_t> offsets = vis::triangleOffsets(city);
  pvs.triangles.resize(2);
  for (uint32_t t = 0; t < pvs.sceneTriangles; ++t) pvs.triangles[0].push_back(t);
  for (uint64_t t = offsets[0]; t < offsets[1]; ++t) pvs.triangles[1].push_back(uint32_t(t));
  ASSERT_TRUE(vis::savePvs(pvsPath.string(), pvs, "gen:city:1").ok());

  const runtime::SceneOptions options{.input = mrg.string(), .pvs = pvsPath.string()};
  auto sequential = runtime::Scene::open(test::gpuContext(), options);
  auto inFlight = runtime::Scene::open(test::gpuContext(), options);
  ASSERT_TRUE(sequential.ok() && inFlight.ok());
  ASSERT_TRUE((*inFlight)->canRecord());
  std::vector<runtime::View> views(render::kMaxFramesInFlight);
  const int cells[] = {0, 1, 0}; // a cell change while the frames before it are in flight
  for (uint32_t i = 0; i < views.size(); ++i) {
    views[i].width = kWidth;
    views[i].height = kHeight;
    views[i].camera = base;
    views[i].camera.eye = pvs.cells[size_t(cells[i])].position + glm::vec3(0.0f, 0.1f * float(i), 0.0f);
    views[i].camera.target = base.target + (views[i].camera.eye - base.eye);
    views[i].readLinear = true;
  }
  std::vector<runtime::Frame> expected;
  for (const runtime::View& v : views) {
    auto f = (*sequential)->render(v);
    ASSERT_TRUE(f.ok()) << f.error().message;
    expected.push_back(std::move(*f));
  }
  EXPECT_NE(expected[0].trianglesDrawn, expected[1].trianglesDrawn); // the slots can be told apart

  std::vector<std::vector<uint16_t>> pixels =
      test::recordFramesInFlight(test::gpuContext(), render::kMaxFramesInFlight, kWidth, kHeight,
                                 [&](VkCommandBuffer cmd, uint32_t slot, const gpu::Image*& color) -> Status {
                                   if (Status st = (*inFlight)->record(cmd, views[slot], slot); !st) return st;
                                   color = (*inFlight)->colorTarget();
                                   return Ok{};
                                 });
  ASSERT_EQ(pixels.size(), size_t(render::kMaxFramesInFlight));

  for (uint32_t i = 0; i < render::kMaxFramesInFlight; ++i) {
    SCOPED_TRACE(i);
    auto out = (*inFlight)->collect(i);
    ASSERT_TRUE(out.ok()) << out.error().message;
    EXPECT_TRUE(out->srgb.pixels.empty()); // no readback on this path
    EXPECT_EQ(out->pvsCell, expected[i].pvsCell);
    EXPECT_EQ(out->pvsCell, cells[i]);
    EXPECT_EQ(out->trianglesDrawn, expected[i].trianglesDrawn);
    EXPECT_EQ(out->clustersDrawn, expected[i].clustersDrawn);
    ASSERT_TRUE(out->cluster && expected[i].cluster);
    EXPECT_EQ(out->cluster->instancesPvsCulled, expected[i].cluster->instancesPvsCulled);
    EXPECT_EQ(out->cluster->clustersSelected, expected[i].cluster->clustersSelected);
    EXPECT_FALSE(out->passTimes.empty());
    EXPECT_EQ(test::differingChannels(pixels[i], expected[i].linear.pixels), 0u)
        << "of " << pixels[i].size() << " channel values";
    EXPECT_FALSE((*inFlight)->collect(i).ok()); // a slot is collected once
  }
}

// A scene file (the forward renderer) records too: three frames in flight, the images and draw
// counts of sequential render() calls.
TEST_F(RuntimeFrames, ForwardScenesRecordFramesInFlight) {
  const runtime::SceneOptions options{.input = "gen:blob:2"};
  auto sequential = runtime::Scene::open(test::gpuContext(), options);
  auto inFlight = runtime::Scene::open(test::gpuContext(), options);
  ASSERT_TRUE(sequential.ok() && inFlight.ok());
  ASSERT_TRUE((*inFlight)->canRecord());
  render::Camera base = render::autoCamera((*sequential)->bounds(), float(kWidth) / float(kHeight));
  std::vector<runtime::View> views(render::kMaxFramesInFlight);
  std::vector<runtime::Frame> expected;
  for (uint32_t i = 0; i < views.size(); ++i) {
    views[i].width = kWidth;
    views[i].height = kHeight;
    views[i].camera = base;
    views[i].camera.eye = glm::mix(base.target, base.eye, 1.0f - 0.2f * float(i));
    views[i].readLinear = true;
    auto f = (*sequential)->render(views[i]);
    ASSERT_TRUE(f.ok()) << f.error().message;
    expected.push_back(std::move(*f));
  }
  std::vector<std::vector<uint16_t>> pixels =
      test::recordFramesInFlight(test::gpuContext(), render::kMaxFramesInFlight, kWidth, kHeight,
                                 [&](VkCommandBuffer cmd, uint32_t slot, const gpu::Image*& color) -> Status {
                                   if (Status st = (*inFlight)->record(cmd, views[slot], slot); !st) return st;
                                   color = (*inFlight)->colorTarget();
                                   return Ok{};
                                 });
  ASSERT_EQ(pixels.size(), size_t(render::kMaxFramesInFlight));
  for (uint32_t i = 0; i < render::kMaxFramesInFlight; ++i) {
    SCOPED_TRACE(i);
    auto out = (*inFlight)->collect(i);
    ASSERT_TRUE(out.ok()) << out.error().message;
    ASSERT_TRUE(out->forward && expected[i].forward);
    EXPECT_EQ(out->forward->stats.drawCalls, expected[i].forward->stats.drawCalls);
    EXPECT_EQ(out->trianglesDrawn, expected[i].trianglesDrawn);
    EXPECT_EQ(test::differingChannels(pixels[i], expected[i].linear.pixels), 0u)
        << "of " << pixels[i].size() << " channel values";
  }
}

// A forward scene with a PVS replaces its renderer on a cell change: render() only.
TEST_F(RuntimeFrames, ScenesWithoutARecordPathSaySo) {
  mirage::Scene blob = io::generateScene("blob", 1, 1).value();
  vis::PvsData pvs;
  pvs.sceneTriangles = blob.instancedTriangleCount();
  pvs.cells.resize(1);
  pvs.triangles.resize(1);
  for (uint32_t t = 0; t < pvs.sceneTriangles; ++t) pvs.triangles[0].push_back(t);
  fs::path pvsPath = test::tempDir("runtime_frames_forward") / "pvs.mrg";
  ASSERT_TRUE(vis::savePvs(pvsPath.string(), pvs, "gen:blob:1").ok());
  auto forward = runtime::Scene::open(test::gpuContext(), {.input = "gen:blob:1", .pvs = pvsPath.string()});
  ASSERT_TRUE(forward.ok()) << forward.error().message;
  EXPECT_FALSE((*forward)->canRecord());
  EXPECT_EQ((*forward)->colorTarget(), nullptr);
  runtime::View v;
  auto st = (*forward)->record(VK_NULL_HANDLE, v, 0);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("render()"), std::string::npos) << st.error().message;
}
