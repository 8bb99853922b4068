#pragma once
// The lit plane of the material tests: a plane facing +Z seen head-on, ambient off so each pixel is
// the direct term only, and docs/shading.md's formulas evaluated on the CPU to compare against.
#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

#include "mirage/render/camera.h"
#include "mirage/render/forward_renderer.h"
#include "mirage/shading/material_file.h"
#include "test_scenes.h"

namespace mirage::test {

inline constexpr float kPi = 3.14159265358979f;
inline constexpr uint32_t kWidth = 64, kHeight = 48;

// A 2h x 2h plane (z = 0, facing +Z) seen head-on from z = 3.
struct Plane {
  float half = 1.0f;
  Scene scene;
  render::RenderSettings settings;
  explicit Plane(float h = 1.0f) : half(h) {
    scene = makeScene({makeQuad(h, 0.0f)}, {solidMaterial({1, 1, 1, 1})});
    scene.meshes[0].name = "plane";
    settings.width = kWidth;
    settings.height = kHeight;
    settings.camera.eye = {0, 0, 3};
    settings.camera.target = {0, 0, 0};
    settings.camera.fovYDegrees = 70.0f;
    settings.skyAmbient = settings.groundAmbient = glm::vec3(0.0f);
    settings.background = {0, 0, 0, 1};
    settings.readLinear = true;
  }
  shaderio::ViewFrame view() const {
    return render::viewFrame(render::withClipPlanes(settings.camera, scene.worldBounds()), kWidth, kHeight);
  }
};

// Applies `toml` (textures resolved in `dir`) to `scene`.
inline void applyToml(Scene& scene, const std::string& toml, const std::filesystem::path& dir = {}) {
  auto file = shading::parseMaterialFile(toml, "test.toml", dir);
  ASSERT_TRUE(file.ok()) << file.error().message;
  ASSERT_TRUE(shading::applyMaterials(scene, *file).ok());
}

inline glm::vec3 rgbAt(const ImageF32& img, uint32_t x, uint32_t y) {
  const float* q = &img.pixels[(size_t(y) * img.width + x) * 4];
  return {q[0], q[1], q[2]};
}

// Where the ray through pixel (x, y)'s centre meets z = 0.
inline glm::vec3 planePoint(const shaderio::ViewFrame& v, uint32_t x, uint32_t y) {
  glm::vec2 ndc{2.0f * (float(x) + 0.5f) / float(kWidth) - 1.0f, 2.0f * (float(y) + 0.5f) / float(kHeight) - 1.0f};
  glm::vec4 a = v.invViewProj * glm::vec4(ndc, 1.0f, 1.0f), b = v.invViewProj * glm::vec4(ndc, 0.5f, 1.0f);
  glm::vec3 p0 = glm::vec3(a) / a.w, p1 = glm::vec3(b) / b.w;
  float t = p0.z / (p0.z - p1.z);
  return p0 + t * (p1 - p0);
}

// Compares every pixel well inside the plane with `expected(point)` (per channel within relTol x
// expected + 2e-3); pixels for which `skip(x, y)` holds are left out. Returns how many were compared.
template <class F, class S> size_t expectPlane(const Plane& p, const ImageF32& img, F expected, float relTol, S skip) {
  shaderio::ViewFrame v = p.view();
  size_t compared = 0, bad = 0;
  for (uint32_t y = 0; y < kHeight; ++y)
    for (uint32_t x = 0; x < kWidth; ++x) {
      glm::vec3 q = planePoint(v, x, y);
      if (std::abs(q.x) > p.half - 0.05f || std::abs(q.y) > p.half - 0.05f || skip(x, y)) continue;
      glm::vec3 want = expected(q), got = rgbAt(img, x, y);
      for (int c = 0; c < 3; ++c)
        if (std::abs(got[c] - want[c]) > relTol * want[c] + 2e-3f && bad++ < 5)
          ADD_FAILURE() << "pixel " << x << "," << y << " (" << q.x << "," << q.y << ") channel " << c << ": got "
                        << got[c] << ", expected " << want[c];
      ++compared;
    }
  EXPECT_EQ(bad, 0u);
  return compared;
}
template <class F> size_t expectPlane(const Plane& p, const ImageF32& img, F expected, float relTol = 0.01f) {
  return expectPlane(p, img, expected, relTol, [](uint32_t, uint32_t) { return false; });
}

// docs/shading.md's point-light falloff: saturate(1 - (d / radius)^4)^2 / (d^2 + 1).
inline float pointLightFalloff(float d, float radius) {
  float x = d / radius;
  float window = std::clamp(1.0f - x * x * x * x, 0.0f, 1.0f);
  return window * window / (d * d + 1.0f);
}

// Radiance of a white Lambertian (Blinn-Phong, no specular) plane point q lit by a point light.
inline glm::vec3 matteUnderPointLight(glm::vec3 q, glm::vec3 light, glm::vec3 colorTimesIntensity, float radius) {
  float d = glm::length(light - q);
  float nl = std::max(light.z - q.z, 0.0f) / d;
  return glm::vec3(1.0f / kPi) * nl * colorTimesIntensity * pointLightFalloff(d, radius);
}

} // namespace mirage::test
