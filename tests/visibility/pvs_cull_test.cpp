// Run-time PVS culling: the restricted scene holds exactly the PVS triangles, and drawing it from
// inside its cell gives the full scene's image (the PVS misses nothing visible there).
#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/core/image_metrics.h"
#include "mirage/io/generate.h"
#include "mirage/render/forward_renderer.h"
#include "mirage/visibility/gvs.h"
#include "mirage/visibility/pvs_cull.h"
#include "mirage/visibility/ray_backend.h"

using namespace mirage;

TEST(PvsCull, RestrictKeepsExactlyTheListedTriangles) {
  Scene scene = io::generateScene("city", 2, 1).value();
  uint64_t total = scene.instancedTriangleCount();
  std::vector<uint32_t> ids;
  for (uint64_t t = 0; t < total; t += 7) ids.push_back(uint32_t(t));
  auto r = vis::restrictToPvs(scene, ids);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->instancedTriangleCount(), ids.size());
  EXPECT_LE(r->instances.size(), scene.instances.size());
  auto none = vis::restrictToPvs(scene, {});
  ASSERT_TRUE(none.ok());
  EXPECT_EQ(none->instancedTriangleCount(), 0u);
  std::vector<uint32_t> outside{uint32_t(total)};
  EXPECT_FALSE(vis::restrictToPvs(scene, outside).ok());
}

TEST(PvsCull, FindCellByContainment) {
  std::vector<vis::ViewCell> cells(2);
  cells[0].position = {0, 0, 0};
  cells[1].position = {5, 0, 0};
  EXPECT_EQ(vis::findCell(cells, {0.2f, 0.1f, -0.3f}), 0);
  EXPECT_EQ(vis::findCell(cells, {5.4f, 0.0f, 0.0f}), 1);
  EXPECT_EQ(vis::findCell(cells, {2.5f, 0.0f, 0.0f}), -1);
}

class PvsCullRender : public test::GpuTest {};

TEST_F(PvsCullRender, PvsImageMatchesFullSceneFromInsideTheCell) {
  Scene scene = io::generateScene("city", 3, 1).value();
  Bounds b = scene.worldBounds();
  vis::ViewCell cell;
  cell.position = {b.center().x * 0.5f + b.min.x * 0.5f, b.min.y + 2.0f, b.center().z};
  cell.size = {4.0f, 2.0f, 4.0f};
  auto backend = vis::createEmbreeBackend(scene);
  ASSERT_TRUE(backend.ok()) << backend.error().message;
  vis::GvsConfig config;
  config.randomRays = 200000;
  config.rayBudget = 2000000;
  vis::CellPvs pvs = vis::computeCellPvs(**backend, scene, cell, config);
  auto restricted = vis::restrictToPvs(scene, pvs.triangles);
  ASSERT_TRUE(restricted.ok());
  ASSERT_LT(restricted->instancedTriangleCount(), scene.instancedTriangleCount());
  auto full = render::ForwardRenderer::create(context(), scene);
  auto part = render::ForwardRenderer::create(context(), *restricted);
  ASSERT_TRUE(full.ok() && part.ok());
  for (int v = 0; v < 4; ++v) {
    render::RenderSettings rs;
    rs.width = 160;
    rs.height = 120;
    rs.camera.eye = cell.position;
    float a = float(v) * 1.5707963f;
    rs.camera.target = cell.position + glm::vec3(std::cos(a), 0.0f, std::sin(a));
    rs.camera.fovYDegrees = 70.0f;
    rs.camera = render::withClipPlanes(rs.camera, b);
    auto x = (*full)->render(rs);
    auto y = (*part)->render(rs);
    ASSERT_TRUE(x.ok() && y.ok());
    EXPECT_GE(psnr(x->srgb, y->srgb), 40.0) << "view " << v;
  }
}
