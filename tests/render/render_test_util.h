#pragma once
// Helpers shared by the renderer tests (and the particle rendering tests): one forward frame, a
// named pass's count, linear pixels, the magenta background no shading produces, and failed images
// written out.
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <glm/glm.hpp>

#include "mirage/core/image.h"
#include "mirage/core/scene.h"
#include "mirage/gpu/context.h"
#include "mirage/gpu/query.h"
#include "mirage/io/image_io.h"
#include "mirage/render/forward_renderer.h"
#include "test_support.h"

namespace mirage::test {

// One frame of `scene` by a fresh forward renderer; a failure fails the test (and returns nothing).
inline render::RenderOutput renderForward(gpu::Context& ctx, const Scene& scene,
                                          const render::ForwardRenderSettings& s) {
  auto r = render::ForwardRenderer::create(ctx, scene);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  if (!r.ok()) return {};
  auto out = (*r)->render(s);
  EXPECT_TRUE(out.ok()) << (out.ok() ? "" : out.error().message);
  return out.ok() ? std::move(*out) : render::RenderOutput{};
}

// How many of a frame's timed passes are called `name`.
inline int passCount(const std::vector<gpu::PassTime>& times, const std::string& name) {
  int n = 0;
  for (const gpu::PassTime& t : times) n += t.name == name;
  return n;
}

// The linear colour of pixel (x, y).
inline glm::vec3 linearRgbAt(const ImageF32& img, uint32_t x, uint32_t y) {
  const float* p = &img.pixels[(size_t(y) * img.width + x) * 4];
  return {p[0], p[1], p[2]};
}

// A background colour no shading of the test objects produces, and whether pixel `pixel` (row-major
// index) shows it.
inline constexpr glm::vec4 kMagenta{1.0f, 0.0f, 1.0f, 1.0f};
inline bool isMagenta(const ImageRGBA8& img, size_t pixel) {
  const uint8_t* p = &img.pixels[pixel * 4];
  return p[0] == 255 && p[1] == 0 && p[2] == 255;
}

// The image as a PNG in the process's temporary directory when the test has failed.
inline void writeOnFailure(const ImageRGBA8& img, const std::string& name) {
  if (!::testing::Test::HasFailure()) return;
  static const std::filesystem::path dir = tempDir("render"); // one per process: tempDir empties it
  auto path = dir / name;
  if (io::writePng(path, img)) std::fprintf(stderr, "wrote %s\n", path.string().c_str());
}

} // namespace mirage::test
