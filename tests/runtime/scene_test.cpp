// runtime::Scene (docs/runtime.md): the path open() picks from the input's contents, one-line
// errors naming the file, frames equal to the renderers called directly, and the view cell's PVS
// switching as the eye moves.
#include <fstream>

#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/runtime/scene.h"
#include "mirage/runtime/scene_argument.h"
#include "mirage/surfels/capture.h"
#include "mirage/surfels/reference.h"
#include "mirage/surfels/surfel_io.h"
#include "mirage/visibility/ray_backend.h"
#include "runtime/runtime_test_util.h"
#include "test_support.h"

using namespace mirage;
using mirage::test::GpuTest;
using test::kViewHeight;
using test::kViewWidth;
namespace fs = std::filesystem;

namespace {

// A small blob baked to a .mrg once for every test here (with its source scene).
struct BlobFixture {
  mirage::Scene scene;
  lod::LodAsset asset;
  fs::path mrg;
};
const BlobFixture& blob() {
  static const BlobFixture f = [] {
    BlobFixture b;
    b.scene = io::generateScene("blob", 1, 3).value();
    b.asset = lod::bakeLodAsset(b.scene, {}).value();
    b.mrg = test::tempDir("runtime_blob") / "blob.mrg";
    if (!lod::saveLodAsset(b.mrg.string(), b.asset).ok()) std::abort();
    return b;
  }();
  return f;
}

std::unique_ptr<runtime::Scene> openOk(const runtime::SceneOptions& o) {
  auto s = runtime::Scene::open(test::gpuContext(), o);
  EXPECT_TRUE(s.ok()) << (s.ok() ? "" : s.error().message);
  return s.ok() ? std::move(*s) : nullptr;
}

bool samePixels(const ImageRGBA8& a, const ImageRGBA8& b) {
  return a.width == b.width && a.height == b.height && a.pixels == b.pixels;
}

// An error for the runtime: one line that names `file`.
void expectOneLineNaming(const Error& e, const std::string& file) {
  EXPECT_EQ(e.message.find('\n'), std::string::npos) << e.message;
  EXPECT_NE(e.message.find(file), std::string::npos) << e.message;
}

} // namespace

class RuntimeScene : public GpuTest {};

TEST_F(RuntimeScene, MrgWithClusterDagsOpensAsClusterLod) {
  auto s = openOk({.input = blob().mrg.string()});
  ASSERT_TRUE(s);
  EXPECT_EQ(s->kind(), runtime::SceneKind::ClusterLod);
  EXPECT_EQ(s->info().instances, blob().asset.scene.instances.size());
  EXPECT_EQ(s->info().sourceTriangles, blob().asset.dags[0].inputTriangles);
  EXPECT_GT(s->info().clusters, 0u);
  ASSERT_NE(s->lodAsset(), nullptr);
  // --grid repeats the instances: 3 x 3 copies.
  auto g = openOk({.input = blob().mrg.string(), .grid = 3});
  ASSERT_TRUE(g);
  EXPECT_EQ(g->info().instances, 9 * blob().asset.scene.instances.size());
  EXPECT_GT(g->bounds().extent().x, 2.0f * s->bounds().extent().x);
}

TEST_F(RuntimeScene, SceneFilesAndGeneratedScenesOpenAsForward) {
  auto g = openOk({.input = "gen:blob:3"});
  ASSERT_TRUE(g);
  EXPECT_EQ(g->kind(), runtime::SceneKind::Forward);
  EXPECT_EQ(g->info().sourceTriangles, blob().scene.instancedTriangleCount());
  EXPECT_EQ(g->lodAsset(), nullptr);
  fs::path obj = test::tempDir("runtime_obj") / "tri.obj";
  std::ofstream(obj) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  auto o = openOk({.input = obj.string()});
  ASSERT_TRUE(o);
  EXPECT_EQ(o->kind(), runtime::SceneKind::Forward);
  EXPECT_EQ(o->info().sourceTriangles, 1u);
  auto f = o->render(test::viewOf(*o, kViewWidth, kViewHeight));
  ASSERT_TRUE(f.ok()) << f.error().message;
  ASSERT_TRUE(f->forward.has_value());
  EXPECT_EQ(f->forward->triangles, 1u);
  EXPECT_EQ(f->srgb.width, kViewWidth);
}

TEST_F(RuntimeScene, SurfelOnlyFileOpensAsSurfels) {
  surfels::CaptureConfig config;
  config.resolution = 32;
  surfels::GBufferTexels texels = surfels::captureGBuffer(context(), blob().scene, config).value().texels;
  surfels::SurfelCloud cloud = surfels::buildSurfelCloud(texels, surfels::farthestPointReference(texels, 2000));
  fs::path mrg = test::tempDir("runtime_surfels") / "s.mrg";
  ASSERT_TRUE(surfels::writeSurfelMrg(mrg.string(), cloud).ok());
  // Without --surfels the file is refused, naming the flag it needs.
  auto kind = runtime::sceneKind({.input = mrg.string()});
  ASSERT_FALSE(kind.ok());
  expectOneLineNaming(kind.error(), mrg.string());
  EXPECT_NE(kind.error().message.find("--surfels"), std::string::npos);
  auto s = openOk({.input = mrg.string(), .surfels = true});
  ASSERT_TRUE(s);
  EXPECT_EQ(s->kind(), runtime::SceneKind::Surfels);
  EXPECT_EQ(s->info().surfels, cloud.size());
  auto f = s->render(test::viewOf(*s, kViewWidth, kViewHeight));
  ASSERT_TRUE(f.ok()) << f.error().message;
  ASSERT_TRUE(f->surfels.has_value());
  EXPECT_EQ(f->surfels->visibleInstances, 1u);
  EXPECT_GT(f->surfelsSplatted, 0u);
}

TEST_F(RuntimeScene, BadInputIsOneLineNamingTheFile) {
  fs::path dir = test::tempDir("runtime_bad");
  fs::path garbage = dir / "garbage.mrg", missing = dir / "missing.obj";
  std::ofstream(garbage) << "not a mirage asset";
  for (const fs::path& p : {garbage, missing}) {
    auto s = runtime::Scene::open(context(), {.input = p.string()});
    ASSERT_FALSE(s.ok()) << p;
    expectOneLineNaming(s.error(), p.filename().string());
  }
  auto pvs = runtime::Scene::open(context(), {.input = blob().mrg.string(), .pvs = missing.string()});
  ASSERT_FALSE(pvs.ok());
  expectOneLineNaming(pvs.error(), "missing.obj");
  auto grid = runtime::Scene::open(context(), {.input = blob().mrg.string(), .grid = 0});
  ASSERT_FALSE(grid.ok());
  EXPECT_NE(grid.error().message.find("--grid"), std::string::npos);
  // render() validates the view's config before drawing.
  auto s = openOk({.input = blob().mrg.string()});
  ASSERT_TRUE(s);
  runtime::View view = test::viewOf(*s, kViewWidth, kViewHeight);
  view.config.tauPixels = -1.0f;
  auto f = s->render(view);
  ASSERT_FALSE(f.ok());
  EXPECT_NE(f.error().message.find("--tau"), std::string::npos);
}

TEST(RuntimeConfig, ValidateNamesTheFlag) {
  EXPECT_TRUE(runtime::validate(runtime::RenderConfig{}).ok());
  runtime::RenderConfig c;
  c.tauPixels = 0.0f;
  EXPECT_NE(runtime::validate(c).error().message.find("--tau"), std::string::npos);
  c = {};
  c.hybridThreshold = -1.0f;
  EXPECT_NE(runtime::validate(c).error().message.find("--hybrid-threshold"), std::string::npos);
  c = {};
  c.surfelSize = 100.0f;
  EXPECT_NE(runtime::validate(c).error().message.find("--surfel-size"), std::string::npos);
  // The defaults are the renderers' own.
  EXPECT_EQ(runtime::RenderConfig{}.tauPixels, render::ClusterRenderSettings{}.tauPixels);
  EXPECT_EQ(runtime::RenderConfig{}.hybridThreshold, render::ClusterRenderSettings{}.hybridThreshold);
  EXPECT_EQ(runtime::RenderConfig{}.surfelSize, render::SurfelRenderSettings{}.surfelSize);
}

// A frame through the runtime is the renderer's frame, bit for bit (cluster LOD and forward).
TEST_F(RuntimeScene, FrameEqualsTheRendererCalledDirectly) {
  auto s = openOk({.input = blob().mrg.string()});
  ASSERT_TRUE(s);
  runtime::View view = test::viewOf(*s, kViewWidth, kViewHeight);
  view.config.tauPixels = 2.0f;
  view.config.raster = render::RasterBackend::Indirect;
  auto f = s->render(view);
  ASSERT_TRUE(f.ok()) << f.error().message;
  // The renderer on the asset as read back (the file stores quantized geometry).
  auto loaded = lod::loadLodAsset(blob().mrg.string());
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  auto direct = render::ClusterRenderer::create(context(), *loaded);
  ASSERT_TRUE(direct.ok()) << direct.error().message;
  render::ClusterRenderSettings rs;
  rs.base.width = kViewWidth;
  rs.base.height = kViewHeight;
  rs.base.camera = view.camera;
  rs.tauPixels = 2.0f;
  rs.raster = render::RasterBackend::Indirect;
  auto d = (*direct)->render(rs);
  ASSERT_TRUE(d.ok()) << d.error().message;
  EXPECT_TRUE(samePixels(f->srgb, d->image.srgb));
  ASSERT_TRUE(f->cluster.has_value());
  EXPECT_EQ(f->trianglesDrawn, d->stats.trianglesRasterized);
  EXPECT_EQ(f->cluster->clustersSelected, d->stats.clustersSelected);
  EXPECT_GT(f->trianglesDrawn, 0u);

  auto g = openOk({.input = "gen:blob:3"});
  ASSERT_TRUE(g);
  auto gf = g->render(view);
  ASSERT_TRUE(gf.ok()) << gf.error().message;
  auto fw = render::ForwardRenderer::create(context(), blob().scene);
  ASSERT_TRUE(fw.ok());
  render::RenderSettings frs;
  frs.width = kViewWidth;
  frs.height = kViewHeight;
  frs.camera = view.camera;
  auto fd = (*fw)->render(frs);
  ASSERT_TRUE(fd.ok());
  EXPECT_TRUE(samePixels(gf->srgb, fd->srgb));
}

// Two view cells of a small city: A sees everything, B only instance 0. Moving the eye from A to B
// and back re-uploads the cell's cluster PVS; in B the other instances are culled (and drawn again
// with pvsCulling off); outside every cell nothing is culled.
TEST_F(RuntimeScene, PvsCellSwitchCullsWhatThePvsSays) {
  mirage::Scene city = io::generateScene("city", 1, 1).value();
  fs::path dir = test::tempDir("runtime_pvs");
  fs::path mrg = dir / "city.mrg", pvsPath = dir / "pvs.mrg";
  ASSERT_TRUE(lod::saveLodAsset(mrg.string(), lod::bakeLodAsset(city, {}).value()).ok());
  ASSERT_GT(city.instances.size(), 2u);
  render::Camera base = render::autoCamera(city.worldBounds(), float(kViewWidth) / float(kViewHeight));
  glm::vec3 step = glm::normalize(glm::cross(base.target - base.eye, glm::vec3(0, 1, 0))) * 2.0f;
  vis::PvsData pvs;
  pvs.sceneTriangles = city.instancedTriangleCount();
  pvs.cells.resize(2);
  pvs.cells[0].position = base.eye;
  pvs.cells[1].position = base.eye + step; // cells of size 1, apart
  std::vector<uint64_t> offsets = vis::triangleOffsets(city);
  pvs.triangles.resize(2);
  for (uint32_t t = 0; t < pvs.sceneTriangles; ++t) pvs.triangles[0].push_back(t);
  for (uint64_t t = offsets[0]; t < offsets[1]; ++t) pvs.triangles[1].push_back(uint32_t(t));
  ASSERT_TRUE(vis::savePvs(pvsPath.string(), pvs, "gen:city:1").ok());

  auto s = openOk({.input = mrg.string(), .pvs = pvsPath.string()});
  ASSERT_TRUE(s);
  ASSERT_NE(s->pvsData(), nullptr);
  runtime::View view = test::viewOf(*s, kViewWidth, kViewHeight);
  auto render = [&](glm::vec3 eye, bool culling) {
    view.camera = base;
    view.camera.eye = eye;
    view.camera.target = base.target + (eye - base.eye);
    view.config.pvsCulling = culling;
    auto f = s->render(view);
    EXPECT_TRUE(f.ok()) << f.error().message;
    return std::move(*f);
  };
  runtime::Frame a = render(pvs.cells[0].position, true);
  EXPECT_EQ(a.pvsCell, 0);
  EXPECT_EQ(a.cluster->instancesPvsCulled, 0u);
  EXPECT_EQ(s->pvs().visibleInstances, city.instances.size());

  EXPECT_TRUE(s->selectPvsCell(pvs.cells[1].position).value()); // the cell changes
  runtime::Frame b = render(pvs.cells[1].position, true);
  EXPECT_EQ(b.pvsCell, 1);
  EXPECT_EQ(s->pvs().visibleInstances, 1u);
  EXPECT_EQ(s->pvs().cellTriangles, offsets[1] - offsets[0]);
  EXPECT_GT(b.cluster->instancesPvsCulled, 0u);
  runtime::Frame bOff = render(pvs.cells[1].position, false);
  EXPECT_EQ(bOff.pvsCell, -1);
  EXPECT_EQ(bOff.cluster->instancesPvsCulled, 0u);
  EXPECT_LT(b.trianglesDrawn, bOff.trianglesDrawn);

  runtime::Frame back = render(pvs.cells[0].position, true);
  EXPECT_EQ(back.pvsCell, 0);
  EXPECT_EQ(back.cluster->instancesPvsCulled, 0u);
  EXPECT_EQ(back.trianglesDrawn, a.trianglesDrawn);

  runtime::Frame outside = render(base.eye - 10.0f * step, true);
  EXPECT_EQ(outside.pvsCell, -1);
  EXPECT_EQ(s->pvs().cell, -1);
  EXPECT_EQ(outside.cluster->instancesPvsCulled, 0u);

  // The forward path: the scene restricted to the cell's PVS; an eye in no cell is an error naming the PVS.
  auto fwd = openOk({.input = "gen:city:1", .pvs = pvsPath.string()});
  ASSERT_TRUE(fwd);
  view.camera = base;
  view.camera.eye = pvs.cells[1].position;
  auto fb = fwd->render(view);
  ASSERT_TRUE(fb.ok()) << fb.error().message;
  EXPECT_EQ(fb->pvsCell, 1);
  EXPECT_EQ(fb->forward->triangles, offsets[1] - offsets[0]);
  view.camera.eye = base.eye - 10.0f * step;
  auto fo = fwd->render(view);
  ASSERT_FALSE(fo.ok());
  expectOneLineNaming(fo.error(), "pvs.mrg");
}

// RenderConfig::drawSurfels (the viewer's surfels switch): a mixed scene seen from far away splats
// its surfels; switched off, the same view draws the meshes and no surfel.
TEST_F(RuntimeScene, MixedSceneSurfelsSwitchOff) {
  surfels::CaptureConfig config;
  config.resolution = 32;
  surfels::GBufferTexels texels = surfels::captureGBuffer(context(), blob().scene, config).value().texels;
  surfels::MeshSurfels cloud{0, surfels::buildSurfelCloud(texels, surfels::farthestPointReference(texels, 2000))};
  fs::path mrg = test::tempDir("runtime_mixed") / "mixed.mrg";
  fs::copy_file(blob().mrg, mrg, fs::copy_options::overwrite_existing);
  ASSERT_TRUE(surfels::appendSurfelMrg(mrg.string(), std::span(&cloud, 1)).ok());
  auto s = openOk({.input = mrg.string(), .surfels = true});
  ASSERT_TRUE(s);
  runtime::View view = test::viewOf(*s, kViewWidth, kViewHeight);
  view.config.raster = render::RasterBackend::Compute; // mesh + surfel frames share the 64-bit buffer
  glm::vec3 centre = s->bounds().center();
  view.camera.eye = centre + (view.camera.eye - centre) * 40.0f; // far: surfels replace the meshes
  auto on = s->render(view);
  ASSERT_TRUE(on.ok()) << on.error().message;
  EXPECT_GT(on->surfelsSplatted, 0u);
  view.config.drawSurfels = false;
  auto off = s->render(view);
  ASSERT_TRUE(off.ok()) << off.error().message;
  EXPECT_EQ(off->surfelsSplatted, 0u);
  EXPECT_GT(off->trianglesDrawn, 0u);
}
