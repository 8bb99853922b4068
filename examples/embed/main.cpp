// Renders one frame of a baked .mrg scene to a PNG through the Mirage libraries.
// Usage: mirage_embed SCENE.mrg OUT.png [WIDTHxHEIGHT [CAMERA]]
//   CAMERA as `mirage render --camera`: "eye=x,y,z,target=x,y,z,fov=60"; default: the 3/4 view.
#include <cstdio>

#include "mirage/gpu/context.h"
#include "mirage/io/image_io.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/camera.h"
#include "mirage/render/cluster_renderer.h"

static int fail(const mirage::Error& error) {
  std::fprintf(stderr, "mirage_embed: error: %s\n", error.message.c_str());
  return 2;
}

int main(int argc, char** argv) {
  unsigned width = 640, height = 360;
  if (argc < 3 || argc > 5 || (argc > 3 && std::sscanf(argv[3], "%ux%u", &width, &height) != 2)) {
    std::fprintf(stderr, "usage: mirage_embed SCENE.mrg OUT.png [WIDTHxHEIGHT [CAMERA]]\n");
    return 2;
  }
  auto asset = mirage::lod::loadLodAsset(argv[1]); // validates every chunk
  if (!asset) return fail(asset.error());
  auto context = mirage::gpu::Context::create(); // MIRAGE_DEVICE, MIRAGE_VALIDATION apply
  if (!context) return fail(context.error());
  auto renderer = mirage::render::ClusterRenderer::create(**context, *asset);
  if (!renderer) return fail(renderer.error());

  mirage::render::ClusterRenderSettings settings; // tau 1 px, automatic raster backend
  settings.base.width = width;
  settings.base.height = height;
  settings.base.camera = mirage::render::autoCamera((*renderer)->worldBounds(), float(width) / float(height));
  if (argc > 4) {
    auto camera = mirage::render::parseCamera(argv[4]);
    if (!camera) return fail(camera.error());
    settings.base.camera = *camera;
  }
  auto frame = (*renderer)->render(settings);
  if (!frame) return fail(frame.error());
  if (auto written = mirage::io::writePng(argv[2], frame->image.srgb); !written) return fail(written.error());

  std::printf("%s: %ux%u, %llu triangles in %llu clusters\n", argv[2], width, height,
              (unsigned long long)frame->stats.trianglesRasterized, (unsigned long long)frame->stats.clustersDrawn);
  // With MIRAGE_VALIDATION=1 the Vulkan validation layers must stay silent.
  return (*context)->validationIssues() == 0 ? 0 : 1;
}
