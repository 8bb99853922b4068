// A large textured quad seen close up: two triangles hundreds of pixels across, far more than the
// largest atlas block (128 texels) resolves. Streamed with tessellation (stream/tessellate.h) it
// matches local rendering; as two triangles its texture is magnified and blurs.
#include <fstream>
#include <random>

#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/io/gltf_write.h"
#include "mirage/stream/bench.h"
#include "test_scenes.h"
#include "test_support.h"

namespace mirage {
class StreamTessellation : public test::GpuTest {};

namespace {

// A 10 x 10 quad (z = 0, facing +z) with a 1024^2 texture of random 8-texel cells: 102 texels per
// unit, about twice the pixels per unit the cameras below see.
std::filesystem::path writeQuadScene(const std::filesystem::path& dir) {
  Material material = test::solidMaterial({1, 1, 1, 1});
  material.metallicFactor = 0.0f;
  material.roughnessFactor = 1.0f;
  material.baseColorTexture = 0;
  Scene scene = test::makeScene({test::makeQuad(5.0f, 0.0f)}, {material});
  Texture texture;
  texture.name = "cells";
  texture.width = texture.height = 1024;
  texture.rgba8.resize(size_t(1024) * 1024 * 4);
  std::mt19937 rng(17);
  std::vector<glm::u8vec4> cells(128 * 128);
  for (glm::u8vec4& c : cells) c = {uint8_t(rng() % 256), uint8_t(rng() % 256), uint8_t(rng() % 256), 255};
  for (uint32_t y = 0; y < 1024; ++y)
    for (uint32_t x = 0; x < 1024; ++x) {
      glm::u8vec4 c = cells[(y / 8) * 128 + x / 8];
      std::copy(&c.x, &c.x + 4, &texture.rgba8[(size_t(y) * 1024 + x) * 4]);
    }
  scene.textures.push_back(std::move(texture));
  std::filesystem::path path = dir / "quad.glb";
  Status s = io::writeGlb(scene, path);
  EXPECT_TRUE(s) << s.error().message;
  return path;
}

TEST_F(StreamTessellation, CloseUpTexturedQuadMatchesLocalRendering) {
  std::filesystem::path dir = test::tempDir("stream_tessellation");
  stream::StreamBenchConfig c;
  c.input = writeQuadScene(dir).string();
  // Three cameras 2-3 units from the quad, two slightly oblique: its triangles' edges span 500-1100
  // pixels. (Steeply oblique views differ from local rendering for another reason: the atlas picks
  // texture mips by the texel footprint, the forward renderer by the pixel's.)
  c.path = (dir / "cameras.json").string();
  std::ofstream(c.path) << R"([{"eye": [0, 0, 3], "target": [0, 0, 0], "fov": 60},
    {"eye": [1, 0.5, 2.5], "target": [0.5, 0.2, 0], "fov": 60},
    {"eye": [-1, -0.5, 2], "target": [-0.5, -0.2, 0], "fov": 60}])";
  c.width = 320;
  c.height = 180;
  c.atlasSize = 1024;
  c.codec = stream::AtlasCodec::ZstdTiles; // lossless: what is measured is the atlas's resolution
  auto run = [&](float maxPatchEdge) {
    c.tessellation.maxPatchEdge = maxPatchEdge;
    auto report = stream::runStreamBench(context(), c);
    EXPECT_TRUE(report) << report.error().message;
    if (!report) return 0.0;
    std::printf("max patch edge %g: %llu triangles, %u patches, SSIM mean %.4f min %.4f, PSNR %.2f dB\n",
                double(maxPatchEdge), (unsigned long long)report->tessellation.trianglesAfter, report->patches,
                report->meanSsim, report->minSsim, report->meanPsnr);
    return report->minSsim;
  };
  // Edges of at most 1 unit cover at most about 80 pixels here (2 units away): within one block.
  EXPECT_GE(run(1.0f), 0.98);
  // Without tessellation the quad is one 2-triangle patch of at most 128 x 128 texels.
  EXPECT_LT(run(std::numeric_limits<float>::infinity()), 0.98);
}

} // namespace
} // namespace mirage
