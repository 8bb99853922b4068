#pragma once
// Shading Atlas Streaming, the server's GPU stages (docs/stream.md, "The server's GPU stages"): which patches a
// client's views see (visibility) and the object-space shading of their atlas blocks (shade),
// with the one material model the forward renderer uses. One per served scene; no networking:
// the session logic decides which patches get which block and sends the results.
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "mirage/core/image.h"
#include "mirage/core/named_enum.h"
#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/gpu/context.h"
#include "mirage/gpu/memory.h"
#include "mirage/gpu/query.h"
#include "mirage/render/camera.h"
#include "mirage/shaderio/atlas.h"
#include "mirage/shaderio/atlas_shading.h"

namespace mirage::render {

// How visibility() finds the patches (docs/stream.md, "Visibility stage").
enum class AtlasVisibilityMethod {
  Auto,     // Compute where the device has 64-bit buffer and shared atomics, else Hardware
  Compute,  // the cluster renderer's compute raster: a depth raster into a 64-bit buffer, then
            // marking rasters (a few dispatches a frame); also marks surfaces that tie with the
            // nearest within MIRAGE_ATLAS_DEPTH_TOLERANCE (shaderio/atlas_shading.h)
  Hardware, // per camera a depth prepass and a marking pass, a draw per instance each
};
inline constexpr EnumName<AtlasVisibilityMethod> kAtlasVisibilityMethodNames[] = {
    {AtlasVisibilityMethod::Auto, "auto"},
    {AtlasVisibilityMethod::Compute, "compute"},
    {AtlasVisibilityMethod::Hardware, "hardware"}};

struct AtlasShadingConfig {
  uint32_t atlasSide = 2048;   // texels; a multiple of the superblock side (128), at most 16384
  uint32_t maxPatches = 65536; // blocks shade() accepts per call (its buffers are sized by it)
  AtlasVisibilityMethod visibility = AtlasVisibilityMethod::Auto;
};

// The forward renderer's key light and ambient (RenderSettings' defaults); the scene's point
// lights are added as there.
struct AtlasLighting {
  glm::vec3 lightDirection{0.35f, 1.0f, 0.45f}; // towards the light, world space (normalized on use)
  float lightIntensity = 2.6f;
  glm::vec3 skyAmbient{0.32f, 0.34f, 0.38f};
  glm::vec3 groundAmbient{0.12f, 0.11f, 0.10f};
};

// The atlas as YUV 4:2:0 in host memory (AtlasShading::convertAtlasYuv; the layout and the
// conversion: shaderio/atlas_shading.h, "AtlasYuvPush"). A server keeps one per H.264 client, so
// that client's frame can be encoded while the atlas is shaded for the next.
// Texels written into the atlas from the host (AtlasShading::writeAtlasRegions): `image` at (x, y).
struct AtlasRegionWrite {
  uint32_t x = 0, y = 0;
  const ImageRGBA8* image = nullptr;
};

struct AtlasYuvImage {
  uint32_t side = 0;         // the atlas side: luma width
  bool stackedAlpha = false; // twice the atlas height, the alpha below the colour
  gpu::Buffer buffer;        // host-visible, coherent: the I420 planes

  uint32_t height() const { return shaderio::atlasYuvHeight(side, stackedAlpha); }
  // Y (side x height), U, V (side/2 x height/2), back to back.
  std::span<const uint8_t> i420() const { return {buffer.mapped(), shaderio::atlasYuvBytes(side, stackedAlpha)}; }
};

class AtlasShading {
public:
  // Uploads the scene (geometry as the forward renderer merges it, materials, textures, point
  // lights) and `patchOfTriangle`: global triangle id -> global patch id, global triangle ids
  // instance-major as the PVS's (vis::triangleOffsets). Patch ids are 0..max; an id no triangle
  // names is simply never visible. Errors: a size that does not match the scene's triangles, an
  // instance naming a missing mesh, a patch id not below the triangle count, a config outside
  // its range, Compute visibility where the device lacks its atomics.
  static Result<std::unique_ptr<AtlasShading>> create(gpu::Context& context, const Scene& scene,
                                                      std::vector<uint32_t> patchOfTriangle,
                                                      const AtlasShadingConfig& config = {});
  ~AtlasShading();

  uint32_t patchCount() const; // max patch id + 1
  uint32_t atlasSide() const;
  AtlasVisibilityMethod visibilityMethod() const; // Compute or Hardware (Auto resolved)

  // The global patch ids (sorted) that any of `cameras` (1-2: the current and the predicted view)
  // sees in a width x height image: opaque and MASK patches with a pixel in front (Compute: or
  // tying with the front one), BLEND patches with a pixel not behind opaque/MASK geometry. Clip
  // planes are derived from the scene where the camera leaves them zero, as the forward renderer
  // does. Synchronous (submits and waits); GPU time in takePassTimes() as "visibility".
  Result<std::vector<uint32_t>> visibility(std::span<const Camera> cameras, uint32_t width, uint32_t height);

  // Shades each patch's block of the atlas (its other texels keep their contents): RGBA8, colour
  // sRGB-encoded as the forward renderer's 8-bit output, alpha linear (BLEND: base alpha; MASK: 0
  // or 1 by the cutoff; OPAQUE: 1). `eye`: where view-dependent terms look from. Errors (a vertex,
  // instance or material index outside the scene, a block outside the atlas or of a bad size,
  // more than maxPatches) shade nothing. Synchronous.
  Status shade(std::span<const shaderio::GpuAtlasPatch> patches, const AtlasLighting& lighting, glm::vec3 eye);
  // GPU times (timestamp queries) of the submissions since the last call: "visibility", "clear",
  // "shade", "colours", one entry per call, in call order.
  std::vector<gpu::PassTime> takePassTimes();
  // Zeroes the whole atlas (a server shading for several clients in turn clears between them, so a
  // client's atlas holds only its own blocks). Synchronous.
  void clearAtlas();
  // The whole atlas image as shade() left it (zero where nothing was shaded yet).
  ImageRGBA8 readAtlas();
  // A YUV image of this atlas for convertAtlasYuv (stackedAlpha: the alpha below the colour).
  AtlasYuvImage createYuvImage(bool stackedAlpha);
  // Converts the atlas as shade() left it into `image` (one compute pass into device memory, then a
  // copy to the host: 1.5 bytes a texel where readAtlas reads 4; the copy is the pass "yuv.copy"). Synchronous; GPU
  // time in takePassTimes() as "yuv". Errors: an image made for another atlas side.
  Status convertAtlasYuv(AtlasYuvImage& image);
  // Host texels into the atlas (texels shaded elsewhere: streamed particles' looks), after the
  // shading of this frame and before its read-back. Synchronous; GPU time as "upload". Errors: a
  // region leaving the atlas or without texels.
  Status writeAtlasRegions(std::span<const AtlasRegionWrite> writes);
  // The width x height texels at (x, y) only (the blocks shaded this frame: a dirty rectangle).
  // Errors: an empty rectangle or one leaving the atlas.
  Result<ImageRGBA8> readAtlasRegion(uint32_t x, uint32_t y, uint32_t width, uint32_t height);

  // Colour-only patches: per global patch id one RGBA8 colour (encoded as the atlas), the shading
  // of the patch's centroid (area-weighted, on the patch triangle nearest to it) with the
  // patch's material. Errors: an id no triangle names.
  Result<std::vector<glm::u8vec4>> shadeColours(std::span<const uint32_t> patchIds, const AtlasLighting& lighting,
                                                glm::vec3 eye);

  struct Impl;

private:
  explicit AtlasShading(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

// The index of mesh `mesh`'s first vertex in the merged vertex buffer that GpuAtlasPatch::vertices
// index (the forward renderer's order: meshes in scene order, each mesh's vertices in order).
std::vector<uint32_t> atlasMeshFirstVertex(const Scene& scene);

} // namespace mirage::render
