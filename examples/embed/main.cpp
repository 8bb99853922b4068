// Renders one frame of a scene to a PNG through the Mirage runtime (runtime::Scene, the library the
// CLI and the viewer render through): a baked .mrg goes to the cluster-LOD renderer, a scene file
// (.gltf .glb .obj .ply) to the forward renderer.
// Usage: mirage_embed SCENE OUT.png [WIDTHxHEIGHT [CAMERA]]
//   CAMERA as `mirage render --camera`: "eye=x,y,z,target=x,y,z,fov=60"; default: the 3/4 view.
#include <cstdio>

#include "mirage/gpu/context.h"
#include "mirage/io/image_io.h"
#include "mirage/render/camera.h"
#include "mirage/runtime/scene.h"

static int fail(const mirage::Error& error) {
  std::fprintf(stderr, "mirage_embed: error: %s\n", error.message.c_str());
  return 2;
}

int main(int argc, char** argv) {
  unsigned width = 640, height = 360;
  if (argc < 3 || argc > 5 || (argc > 3 && std::sscanf(argv[3], "%ux%u", &width, &height) != 2)) {
    std::fprintf(stderr, "usage: mirage_embed SCENE OUT.png [WIDTHxHEIGHT [CAMERA]]\n");
    return 2;
  }
  auto context = mirage::gpu::Context::create(); // MIRAGE_DEVICE, MIRAGE_VALIDATION apply
  if (!context) return fail(context.error());
  auto scene = mirage::runtime::Scene::open(**context, {.input = argv[1]}); // validates every chunk
  if (!scene) return fail(scene.error());

  mirage::runtime::View view; // RenderConfig defaults: tau 1 px, automatic raster backend
  view.width = width;
  view.height = height;
  view.camera = mirage::render::autoCamera((*scene)->bounds(), float(width) / float(height));
  if (argc > 4) {
    auto camera = mirage::render::parseCamera(argv[4]);
    if (!camera) return fail(camera.error());
    view.camera = *camera;
  }
  auto frame = (*scene)->render(view);
  if (!frame) return fail(frame.error());
  if (auto written = mirage::io::writePng(argv[2], frame->srgb); !written) return fail(written.error());

  std::printf("%s: %ux%u, %llu triangles in %llu clusters\n", argv[2], width, height,
              (unsigned long long)frame->trianglesDrawn, (unsigned long long)frame->clustersDrawn);
  // With MIRAGE_VALIDATION=1 the Vulkan validation layers must stay silent.
  return (*context)->validationIssues() == 0 ? 0 : 1;
}
