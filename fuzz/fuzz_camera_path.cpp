// Camera paths (`mirage render|view --path cams.json`, render::loadCameraPath). What the loader
// accepts must be a usable camera: finite, a view direction and an up vector that make a finite
// view matrix, clip planes unset or positive, finite and ordered; written back with
// writeCameraPath it must load as the same cameras. Rejections are one line.
#include <cmath>

#include "fuzz_support.h"
#include "mirage/render/camera.h"

using namespace mirage;

namespace {

bool finite(glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

void checkCamera(const render::Camera& c) {
  fuzz::check(finite(c.eye) && finite(c.target) && finite(c.up), "an accepted camera is not finite");
  fuzz::check(c.fovYDegrees > 1.0f && c.fovYDegrees < 179.0f, "an accepted camera's fov is out of range");
  const glm::mat4 view = c.view();
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) fuzz::check(std::isfinite(view[i][j]), "an accepted camera gives a non-finite view");
  for (float plane : {c.znear, c.zfar})
    fuzz::check(plane == 0.0f || (plane > 0.0f && std::isfinite(plane)), "a clip plane is not positive and finite");
  fuzz::check(c.znear == 0.0f || c.zfar == 0.0f || c.zfar > c.znear, "zfar does not exceed znear");
}

bool same(const render::Camera& a, const render::Camera& b) {
  return a.eye == b.eye && a.target == b.target && a.up == b.up && a.fovYDegrees == b.fovYDegrees &&
         a.znear == b.znear && a.zfar == b.zfar;
}

} // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const auto path = fuzz::writeScratch("cams.json", std::span(data, size));
  Result<std::vector<render::Camera>> cameras = render::loadCameraPath(path);
  if (!cameras) {
    fuzz::checkOneLine(cameras.error());
    return 0;
  }
  fuzz::check(!cameras->empty(), "an accepted path has no camera");
  for (const render::Camera& c : *cameras) checkCamera(c);
  const auto back = fuzz::scratchDir() / "back.json";
  Status written = render::writeCameraPath(back, *cameras);
  if (!written) fuzz::fail("an accepted path cannot be written: " + written.error().message);
  Result<std::vector<render::Camera>> again = render::loadCameraPath(back);
  if (!again) fuzz::fail("an accepted path written back is rejected: " + again.error().message);
  fuzz::check(again->size() == cameras->size(), "writing a path back changes its camera count");
  for (size_t i = 0; i < again->size(); ++i)
    fuzz::check(same((*again)[i], (*cameras)[i]), "writing a path back changes a camera");
  return 0;
}
