// runtime::Scene frames in flight (docs/runtime.md "Frames in flight"): frames recorded into slots
// 0..2 before any wait, the eye changing PVS cell between them (the replaced cluster PVS or forward
// visible triangles must outlive the frames reading them, with no device wait), give the images and
// counters of sequential render() calls.
#include <gtest/gtest.h>

#include <functional>
#include <span>

#include "gpu_test.h"
#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/forward_renderer.h"
#include "mirage/runtime/scene.h"
#include "mirage/runtime/scene_argument.h"
#include "mirage/visibility/pvs_storage.h"
#include "mirage/visibility/ray_backend.h"
#include "runtime/runtime_test_util.h"
#include "test_support.h"

using namespace mirage;
using mirage::test::GpuTest;
using test::kViewHeight;
using test::kViewWidth;
namespace fs = std::filesystem;

class RuntimeFrames : public GpuTest {};

namespace {

// A city, its automatic camera and a PVS saved to `dir`/pvs.mrg with two cells: cell 0 at the
// camera sees every triangle, cell 1 beside it the triangles `cell1` lists (global IDs by instance
// offsets).
struct CityPvs {
  mirage::Scene city = io::generateScene("city", 1, 1).value();
  render::Camera base = render::autoCamera(city.worldBounds(), float(kViewWidth) / float(kViewHeight));
  glm::vec3 step = glm::normalize(glm::cross(base.target - base.eye, glm::vec3(0, 1, 0))) * 2.0f;
  std::vector<uint64_t> offsets = vis::triangleOffsets(city);
  vis::PvsData pvs;
  fs::path path;

  CityPvs(const char* dir, const std::function<std::vector<uint32_t>(const CityPvs&)>& cell1) {
    pvs.sceneTriangles = city.instancedTriangleCount();
    pvs.cells.resize(2);
    pvs.cells[0].position = base.eye;
    pvs.cells[1].position = base.eye + step;
    pvs.triangles.resize(2);
    for (uint32_t t = 0; t < pvs.sceneTriangles; ++t) pvs.triangles[0].push_back(t);
    pvs.triangles[1] = cell1(*this);
    path = test::tempDir(dir) / "pvs.mrg";
    EXPECT_TRUE(vis::savePvs(path.string(), pvs, "gen:city:1").ok());
  }
  // Frame i's view: the eye in cells[i], a little higher each frame of a batch of three.
  std::vector<runtime::View> views(std::span<const int> cells) const {
    std::vector<runtime::View> out(cells.size());
    for (size_t i = 0; i < cells.size(); ++i) {
      out[i].width = kViewWidth;
      out[i].height = kViewHeight;
      out[i].camera = base;
      out[i].camera.eye = pvs.cells[size_t(cells[i])].position + glm::vec3(0.0f, 0.1f * float(i % 3), 0.0f);
      out[i].camera.target = base.target + (out[i].camera.eye - base.eye);
      out[i].readLinear = true;
    }
    return out;
  }
};

std::vector<runtime::Frame> renderEach(runtime::Scene& scene, std::span<const runtime::View> views) {
  std::vector<runtime::Frame> frames;
  for (const runtime::View& v : views) {
    auto f = scene.render(v);
    EXPECT_TRUE(f.ok()) << f.error().message;
    if (f) frames.push_back(std::move(*f));
  }
  return frames;
}

// Records views[0..2] into slots 0..2 before any wait (gateFirstFrame: see recordFramesInFlight),
// collects them and expects what every path reports as in `expected`: the linear image bit for bit,
// the PVS cell, triangles and clusters drawn, pass times; a slot is collected once. Returns the
// collected frames for the path's own counters.
std::vector<runtime::Frame> recordAndCollect(runtime::Scene& scene, std::span<const runtime::View> views,
                                             std::span<const runtime::Frame> expected, bool gateFirstFrame) {
  const VkExtent2D sizes[render::kMaxFramesInFlight] = {
      {kViewWidth, kViewHeight}, {kViewWidth, kViewHeight}, {kViewWidth, kViewHeight}};
  std::vector<std::vector<uint16_t>> pixels = test::recordFramesInFlight(
      test::gpuContext(), sizes,
      [&](VkCommandBuffer cmd, uint32_t slot, const gpu::Image*& color) -> Status {
        if (Status st = scene.record(cmd, views[slot], slot); !st) return st;
        color = scene.colorTarget();
        return Ok{};
      },
      gateFirstFrame);
  std::vector<runtime::Frame> collected;
  if (pixels.size() != render::kMaxFramesInFlight || expected.size() < render::kMaxFramesInFlight) {
    ADD_FAILURE() << "no frames recorded, or none to compare with";
    return collected;
  }
  for (uint32_t i = 0; i < render::kMaxFramesInFlight; ++i) {
    SCOPED_TRACE(i);
    auto out = scene.collect(i);
    EXPECT_TRUE(out.ok()) << out.error().message;
    if (!out) return {};
    EXPECT_TRUE(out->srgb.pixels.empty()); // no readback on this path
    EXPECT_EQ(out->pvsCell, expected[i].pvsCell);
    EXPECT_EQ(out->trianglesDrawn, expected[i].trianglesDrawn);
    EXPECT_EQ(out->clustersDrawn, expected[i].clustersDrawn);
    EXPECT_FALSE(out->passTimes.empty());
    EXPECT_EQ(test::differingChannels(pixels[i], expected[i].linear.pixels), 0u)
        << "of " << pixels[i].size() << " channel values";
    EXPECT_FALSE(scene.collect(i).ok()); // a slot is collected once
    collected.push_back(std::move(*out));
  }
  return collected;
}

} // namespace

TEST_F(RuntimeFrames, ThreeRecordedFramesMatchSequentialRenders) {
  static_assert(render::kMaxFramesInFlight == 3);
  // Cell 1 sees only the first instance.
  CityPvs c("runtime_frames", [](const CityPvs& p) {
    std::vector<uint32_t> ids;
    for (uint64_t t = p.offsets[0]; t < p.offsets[1]; ++t) ids.push_back(uint32_t(t));
    return ids;
  });
  fs::path mrg = c.path.parent_path() / "city.mrg";
  ASSERT_TRUE(lod::saveLodAsset(mrg.string(), lod::bakeLodAsset(c.city, {}).value()).ok());
  const runtime::SceneOptions options{.input = mrg.string(), .pvs = c.path.string()};
  auto sequential = runtime::Scene::open(test::gpuContext(), options);
  auto inFlight = runtime::Scene::open(test::gpuContext(), options);
  ASSERT_TRUE(sequential.ok() && inFlight.ok());
  const int cells[] = {0, 1, 0}; // a cell change while the frames before it are in flight
  std::vector<runtime::View> views = c.views(cells);
  std::vector<runtime::Frame> expected = renderEach(**sequential, views);
  ASSERT_EQ(expected.size(), views.size());
  EXPECT_NE(expected[0].trianglesDrawn, expected[1].trianglesDrawn); // the slots can be told apart

  std::vector<runtime::Frame> out = recordAndCollect(**inFlight, views, expected, false);
  ASSERT_EQ(out.size(), views.size());
  for (uint32_t i = 0; i < out.size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(out[i].pvsCell, cells[i]);
    ASSERT_TRUE(out[i].cluster && expected[i].cluster);
    EXPECT_EQ(out[i].cluster->instancesPvsCulled, expected[i].cluster->instancesPvsCulled);
    EXPECT_EQ(out[i].cluster->clustersSelected, expected[i].cluster->clustersSelected);
  }
}

// A scene file (the forward renderer) records too: three frames in flight, the images and draw
// counts of sequential render() calls.
TEST_F(RuntimeFrames, ForwardScenesRecordFramesInFlight) {
  const runtime::SceneOptions options{.input = "gen:blob:2"};
  auto sequential = runtime::Scene::open(test::gpuContext(), options);
  auto inFlight = runtime::Scene::open(test::gpuContext(), options);
  ASSERT_TRUE(sequential.ok() && inFlight.ok());
  render::Camera base = render::autoCamera((*sequential)->bounds(), float(kViewWidth) / float(kViewHeight));
  std::vector<runtime::View> views(render::kMaxFramesInFlight);
  for (uint32_t i = 0; i < views.size(); ++i) {
    views[i].width = kViewWidth;
    views[i].height = kViewHeight;
    views[i].camera = base;
    views[i].camera.eye = glm::mix(base.target, base.eye, 1.0f - 0.2f * float(i));
    views[i].readLinear = true;
  }
  std::vector<runtime::Frame> expected = renderEach(**sequential, views);
  std::vector<runtime::Frame> out = recordAndCollect(**inFlight, views, expected, false);
  ASSERT_EQ(out.size(), views.size());
  for (uint32_t i = 0; i < out.size(); ++i) {
    SCOPED_TRACE(i);
    ASSERT_TRUE(out[i].forward && expected[i].forward);
    EXPECT_EQ(out[i].forward->stats.drawCalls, expected[i].forward->stats.drawCalls);
  }
}

// A forward scene with a PVS records too: along a camera path that changes cell while earlier frames
// are in flight (the renderer's visible triangles are swapped, the old ones outlive the frames that
// draw them), recorded frames give the images and counters of sequential render() calls, and those
// equal a forward renderer of the scene restricted to the cell's PVS.
TEST_F(RuntimeFrames, ForwardScenesWithAPvsRecordFramesInFlight) {
  // The city has glass (blended draws). Cell 1 sees the first instance's even triangles and the
  // last instance's first half.
  CityPvs c("runtime_frames_forward_pvs", [](const CityPvs& p) {
    std::vector<uint32_t> ids;
    const size_t last = p.city.instances.size() - 1;
    for (uint64_t t = p.offsets[0]; t < p.offsets[1]; t += 2) ids.push_back(uint32_t(t));
    for (uint64_t t = p.offsets[last]; t < (p.offsets[last] + p.offsets[last + 1]) / 2; ++t) ids.push_back(uint32_t(t));
    return ids;
  });
  const runtime::SceneOptions options{.input = "gen:city:1", .pvs = c.path.string()};
  auto sequential = runtime::Scene::open(test::gpuContext(), options);
  auto inFlight = runtime::Scene::open(test::gpuContext(), options);
  ASSERT_TRUE(sequential.ok() && inFlight.ok()) << (sequential.ok() ? "" : sequential.error().message);
  // Two batches of frames in flight, cells 0 1 0 then 1 1 0.
  const int cells[] = {0, 1, 0, 1, 1, 0};
  std::vector<runtime::View> views = c.views(cells);
  std::vector<runtime::Frame> expected = renderEach(**sequential, views);
  ASSERT_EQ(expected.size(), views.size());
  EXPECT_LT(expected[1].trianglesDrawn, expected[0].trianglesDrawn); // the cells can be told apart
  EXPECT_EQ(expected[1].trianglesDrawn, c.pvs.triangles[1].size());
  EXPECT_EQ(expected[1].forward->instances, 2u);

  // render() draws what a renderer of the restricted scene draws.
  for (int cell = 0; cell < 2; ++cell) {
    SCOPED_TRACE(cell);
    int found = -1;
    auto restricted =
        runtime::restrictSceneToPvs(c.city, c.pvs, c.path.string(), views[size_t(cell)].camera.eye, found);
    ASSERT_TRUE(restricted.ok()) << restricted.error().message;
    ASSERT_EQ(found, cell);
    auto renderer = render::ForwardRenderer::create(test::gpuContext(), *restricted);
    ASSERT_TRUE(renderer.ok()) << renderer.error().message;
    render::RenderSettings rs;
    rs.width = kViewWidth;
    rs.height = kViewHeight;
    rs.camera = render::withClipPlanes(views[size_t(cell)].camera, c.city.worldBounds());
    rs.readLinear = true;
    auto direct = (*renderer)->render(rs);
    ASSERT_TRUE(direct.ok()) << direct.error().message;
    EXPECT_EQ(direct->stats.trianglesSubmitted, expected[size_t(cell)].trianglesDrawn);
    EXPECT_TRUE(direct->linear.pixels == expected[size_t(cell)].linear.pixels);
  }

  for (uint32_t first = 0; first < views.size(); first += render::kMaxFramesInFlight) {
    SCOPED_TRACE(first);
    // The first frame is held back on the GPU until all three were recorded: a cell change must not
    // wait for it (no renderer built, no staging upload).
    std::vector<runtime::Frame> out =
        recordAndCollect(**inFlight, std::span(views).subspan(first, 3), std::span(expected).subspan(first, 3), true);
    ASSERT_EQ(out.size(), 3u);
    for (uint32_t slot = 0; slot < out.size(); ++slot) {
      const uint32_t i = first + slot;
      EXPECT_EQ(out[slot].pvsCell, cells[i]);
      ASSERT_TRUE(out[slot].forward && expected[i].forward);
      EXPECT_EQ(out[slot].forward->instances, expected[i].forward->instances);
      EXPECT_EQ(out[slot].forward->stats.drawCalls, expected[i].forward->stats.drawCalls);
      EXPECT_EQ(out[slot].forward->stats.trianglesSubmitted, expected[i].forward->stats.trianglesSubmitted);
    }
  }

  // An eye in no cell records nothing: one line naming the PVS.
  runtime::View outside = views[0];
  outside.camera.eye = c.base.eye - 10.0f * c.step;
  Status st = (*inFlight)->record(VK_NULL_HANDLE, outside, 0);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("pvs.mrg"), std::string::npos) << st.error().message;
}
