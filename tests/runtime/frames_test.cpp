// runtime::Scene frames in flight (docs/runtime.md "Frames in flight"): three frames recorded into
// slots 0..2 before any wait, the eye changing PVS cell between them (the replaced cluster PVS or
// forward visible triangles must outlive the frames reading them, with no device wait), give the
// images and counters of three sequential render() calls.
#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/forward_renderer.h"
#include "mirage/runtime/scene.h"
#include "mirage/runtime/scene_argument.h"
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

// A forward scene with a PVS records too: along a camera path that changes cell while earlier frames
// are in flight (the renderer's visible triangles are swapped, the old ones outlive the frames that
// draw them), recorded frames give the images and counters of sequential render() calls, and those
// equal a forward renderer of the scene restricted to the cell's PVS.
TEST_F(RuntimeFrames, ForwardScenesWithAPvsRecordFramesInFlight) {
  // A city (with glass: blended draws) whose PVS has two cells: cell 0 sees every triangle, cell 1
  // the first instance's even triangles and the last instance's first half.
  mirage::Scene city = io::generateScene("city", 1, 1).value();
  render::Camera base = render::autoCamera(city.worldBounds(), float(kWidth) / float(kHeight));
  glm::vec3 step = glm::normalize(glm::cross(base.target - base.eye, glm::vec3(0, 1, 0))) * 2.0f;
  vis::PvsData pvs;
  pvs.sceneTriangles = city.instancedTriangleCount();
  pvs.cells.resize(2);
  pvs.cells[0].position = base.eye;
  pvs.cells[1].position = base.eye + step;
  std::vector<uint64_t> offsets = vis::triangleOffsets(city);
  const size_t last = city.instances.size() - 1;
  pvs.triangles.resize(2);
  for (uint32_t t = 0; t < pvs.sceneTriangles; ++t) pvs.triangles[0].push_back(t);
  for (uint64_t t = offsets[0]; t < offsets[1]; t += 2) pvs.triangles[1].push_back(uint32_t(t));
  for (uint64_t t = offsets[last]; t < (offsets[last] + offsets[last + 1]) / 2; ++t)
    pvs.triangles[1].push_back(uint32_t(t));
  fs::path pvsPath = test::tempDir("runtime_frames_forward_pvs") / "pvs.mrg";
  ASSERT_TRUE(vis::savePvs(pvsPath.string(), pvs, "gen:city:1").ok());

  const runtime::SceneOptions options{.input = "gen:city:1", .pvs = pvsPath.string()};
  auto sequential = runtime::Scene::open(test::gpuContext(), options);
  auto inFlight = runtime::Scene::open(test::gpuContext(), options);
  ASSERT_TRUE(sequential.ok() && inFlight.ok()) << (sequential.ok() ? "" : sequential.error().message);
  // Two batches of frames in flight, cells 0 1 0 then 1 1 0.
  const int cells[] = {0, 1, 0, 1, 1, 0};
  std::vector<runtime::View> views(std::size(cells));
  std::vector<runtime::Frame> expected;
  for (uint32_t i = 0; i < views.size(); ++i) {
    views[i].width = kWidth;
    views[i].height = kHeight;
    views[i].camera = base;
    views[i].camera.eye = pvs.cells[size_t(cells[i])].position + glm::vec3(0.0f, 0.1f * float(i % 3), 0.0f);
    views[i].camera.target = base.target + (views[i].camera.eye - base.eye);
    views[i].readLinear = true;
    auto f = (*sequential)->render(views[i]);
    ASSERT_TRUE(f.ok()) << f.error().message;
    expected.push_back(std::move(*f));
  }
  EXPECT_LT(expected[1].trianglesDrawn, expected[0].trianglesDrawn); // the cells can be told apart
  EXPECT_EQ(expected[1].trianglesDrawn, pvs.triangles[1].size());
  EXPECT_EQ(expected[1].forward->instances, 2u);

  // render() draws what a renderer of the restricted scene draws.
  for (int cell = 0; cell < 2; ++cell) {
    SCOPED_TRACE(cell);
    int found = -1;
    auto restricted = runtime::restrictSceneToPvs(city, pvs, pvsPath.string(), views[size_t(cell)].camera.eye, found);
    ASSERT_TRUE(restricted.ok()) << restricted.error().message;
    ASSERT_EQ(found, cell);
    auto renderer = render::ForwardRenderer::create(test::gpuContext(), *restricted);
    ASSERT_TRUE(renderer.ok()) << renderer.error().message;
    render::RenderSettings rs;
    rs.width = kWidth;
    rs.height = kHeight;
    rs.camera = render::withClipPlanes(views[size_t(cell)].camera, city.worldBounds());
    rs.readLinear = true;
    auto direct = (*renderer)->render(rs);
    ASSERT_TRUE(direct.ok()) << direct.error().message;
    EXPECT_EQ(direct->stats.trianglesSubmitted, expected[size_t(cell)].trianglesDrawn);
    EXPECT_TRUE(direct->linear.pixels == expected[size_t(cell)].linear.pixels);
  }

  for (uint32_t batch = 0; batch < 2; ++batch) {
    const uint32_t first = batch * render::kMaxFramesInFlight;
    // The first frame is held back on the GPU until all three were recorded: a cell change must not
    // wait for it (no renderer built, no staging upload).
    const VkExtent2D sizes[render::kMaxFramesInFlight] = {{kWidth, kHeight}, {kWidth, kHeight}, {kWidth, kHeight}};
    std::vector<std::vector<uint16_t>> pixels = test::recordFramesInFlight(
        test::gpuContext(), sizes,
        [&](VkCommandBuffer cmd, uint32_t slot, const gpu::Image*& color) -> Status {
          if (Status st = (*inFlight)->record(cmd, views[first + slot], slot); !st) return st;
          color = (*inFlight)->colorTarget();
          return Ok{};
        },
        /*gateFirstFrame=*/true);
    ASSERT_EQ(pixels.size(), size_t(render::kMaxFramesInFlight));
    for (uint32_t slot = 0; slot < render::kMaxFramesInFlight; ++slot) {
      const uint32_t i = first + slot;
      SCOPED_TRACE(i);
      auto out = (*inFlight)->collect(slot);
      ASSERT_TRUE(out.ok()) << out.error().message;
      EXPECT_EQ(out->pvsCell, cells[i]);
      EXPECT_EQ(out->pvsCell, expected[i].pvsCell);
      EXPECT_EQ(out->trianglesDrawn, expected[i].trianglesDrawn);
      ASSERT_TRUE(out->forward && expected[i].forward);
      EXPECT_EQ(out->forward->instances, expected[i].forward->instances);
      EXPECT_EQ(out->forward->stats.drawCalls, expected[i].forward->stats.drawCalls);
      EXPECT_EQ(out->forward->stats.trianglesSubmitted, expected[i].forward->stats.trianglesSubmitted);
      EXPECT_EQ(test::differingChannels(pixels[slot], expected[i].linear.pixels), 0u)
          << "of " << pixels[slot].size() << " channel values";
    }
  }

  // An eye in no cell records nothing: one line naming the PVS.
  runtime::View outside = views[0];
  outside.camera.eye = base.eye - 10.0f * step;
  Status st = (*inFlight)->record(VK_NULL_HANDLE, outside, 0);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("pvs.mrg"), std::string::npos) << st.error().message;
}
