// runtime::RenderConfig::debugView (docs/render.md, "Debug views"): a cluster-LOD scene switches
// the view per frame on the same Scene; other scene kinds refuse it with one line.
#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/camera.h"
#include "mirage/runtime/scene.h"
#include "runtime/runtime_test_util.h"
#include "test_support.h"

using namespace mirage;
using mirage::test::blobMrg;
using test::kViewHeight;
using test::kViewWidth;
namespace fs = std::filesystem;

class RuntimeDebugView : public test::GpuTest {};

// Shaded, each debug view, shaded again: every view changes the image, and switching back gives
// the first image again (nothing of a debug frame stays behind).
TEST_F(RuntimeDebugView, SwitchesPerFrameOnOneScene) {
  auto s = runtime::Scene::open(context(), {.input = blobMrg().string()});
  ASSERT_TRUE(s.ok()) << s.error().message;
  runtime::View view = test::viewOf(**s, kViewWidth, kViewHeight);
  auto shaded = (*s)->render(view);
  ASSERT_TRUE(shaded.ok()) << shaded.error().message;
  for (render::DebugView v :
       {render::DebugView::Clusters, render::DebugView::Lod, render::DebugView::Density, render::DebugView::Overdraw}) {
    SCOPED_TRACE(render::toString(v));
    view.config.debugView = v;
    auto f = (*s)->render(view);
    ASSERT_TRUE(f.ok()) << f.error().message;
    EXPECT_NE(f->srgb.pixels, shaded->srgb.pixels);
  }
  view.config.debugView = render::DebugView::None;
  auto again = (*s)->render(view);
  ASSERT_TRUE(again.ok()) << again.error().message;
  EXPECT_EQ(again->srgb.pixels, shaded->srgb.pixels);
}

TEST_F(RuntimeDebugView, OtherSceneKindsRefuseIt) {
  auto s = runtime::Scene::open(context(), {.input = "gen:blob:3"});
  ASSERT_TRUE(s.ok()) << s.error().message;
  runtime::View view = test::viewOf(**s, kViewWidth, kViewHeight);
  view.config.debugView = render::DebugView::Lod;
  auto f = (*s)->render(view);
  ASSERT_FALSE(f.ok());
  EXPECT_EQ(f.error().message, "--debug-view needs a cluster LOD scene (.mrg with cluster DAGs), not a forward one");
}
