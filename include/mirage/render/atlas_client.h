#pragma once
// The thin client's renderer of Shading Atlas Streaming (docs/stream.md, "The client's renderer"): draws the patches
// the server sent (world positions of their vertices, their atlas blocks or one colour each)
// textured from the latest decoded atlas, at the client's own frame rate. Opaque and MASK patches
// with a depth buffer (reverse-Z), BLEND patches through the forward renderer's per-pixel linked
// lists (render/oit.h) over the opaque colour, with the streamed particles' billboards. No networking or
// decoding: it takes patch and particle records and decoded RGBA8.
#include <array>
#include <cstdint>
#include <memory>
#include <span>

#include <glm/glm.hpp>

#include "mirage/core/image.h"
#include "mirage/core/result.h"
#include "mirage/gpu/context.h"
#include "mirage/render/camera.h"
#include "mirage/render/forward_renderer.h"
#include "mirage/render/frames_in_flight.h"

namespace mirage::render {

struct AtlasClientConfig {
  uint32_t atlasWidth = 4096; // texels, 1..kMaxRenderDimension
  uint32_t atlasHeight = 4096;
  uint32_t maxPatches = 1u << 20; // patch slots on the GPU, 1..2^24
};

enum class PatchAlpha : uint8_t { Opaque, Mask, Blend };

// One patch as the client keeps it (shaderio/atlas.h: its 1-3 triangles, vertex slots a..e).
struct ClientPatch {
  uint32_t triangleCount = 2;           // 1..3: slots a, b, c (1), + d (2), + e (3)
  std::array<glm::vec3, 5> positions{}; // world positions of slots a..e; unused slots ignored
  PatchAlpha alpha = PatchAlpha::Opaque;
  // Its atlas block (first texel, height 2^blockLog2, width atlasBlockWidth), or when colorOnly one
  // colour for the whole patch.
  bool colorOnly = false;
  uint32_t blockX = 0, blockY = 0;
  uint32_t blockLog2 = 1;
  uint32_t color = 0; // colorOnly: RGBA8 as r | g << 8 | b << 16 | a << 24, sRGB rgb like the atlas, linear alpha
};

// One streamed particle as the client draws it (docs/stream.md, "Particles"): a camera-facing
// billboard (as the renderers' particle billboards) textured from its look's block of the atlas
// (shaderio/atlas.h: the tile's mip chain, the level its pixel's footprint picks, as a mipmapped
// fetch picks it) or the look's one colour, times the particle's colour.
struct ClientParticle {
  glm::vec3 position{0.0f};                       // world space, the billboard's centre
  float size = 0.0f;                              // the billboard's edge, world units
  float rotation = 0.0f;                          // radians about the view axis
  uint32_t color = 0;                             // RGBA8 (r in the low byte), linear, straight alpha
  bool colorOnly = false;                         // the look has no block: lookColor instead
  uint32_t blockX = 0, blockY = 0, blockLog2 = 1; // the look's block: 2^(blockLog2 + 1) x 2^blockLog2
  uint32_t lookColor = 0;                         // colorOnly: RGBA8, sRGB rgb like the atlas, linear alpha
};

struct AtlasClientSettings {
  uint32_t width = 1280;
  uint32_t height = 720;
  Camera camera;                                      // clip planes from the bounds of every patch set so far when zero
  glm::vec4 background = RenderSettings{}.background; // linear RGB, the forward renderer's default
  bool readLinear = false;                            // also return the linear float image
  bool readImage = true;                              // false: no readback (empty images)
  uint32_t oitNodesPerPixel = 8;                      // linked lists' pool, fragments per pixel on average (1..64)
};

class AtlasClientRenderer {
public:
  // The atlas texture (RGBA8 sRGB, bilinear, clamped, no mips; black until uploaded) and the slots.
  static Result<std::unique_ptr<AtlasClientRenderer>> create(gpu::Context& context, const AtlasClientConfig& config);
  ~AtlasClientRenderer();

  // Patch `id` (any 32-bit id, the server's global patch id) added or replaced; its slot's record
  // reaches the GPU with the next recorded frame (no device wait). Errors (triangle count, block
  // size or a block outside the atlas, every slot in use) change nothing.
  Status setPatch(uint32_t id, const ClientPatch& patch);
  // Patch `id` drawn no more from the next frame on; its slot is reused. An unknown id is an error.
  Status removePatch(uint32_t id);
  size_t patchCount() const;
  // The particles the next recorded frames draw (replacing the last call's), in the transparency
  // pass with the BLEND patches: each fragment appended to its pixel's linked list, depth-tested
  // against the opaque patches. Errors (a block outside the atlas or of a bad size, a value that is
  // not finite) change nothing.
  Status setParticles(std::span<const ClientParticle> particles);
  size_t particleCount() const;

  // The whole atlas (atlasWidth x atlasHeight RGBA8, sRGB rgb) or a rectangle of it, uploaded by
  // the next recorded frame before it draws; later uploads of the same texels win. Errors (size,
  // a rectangle outside the atlas) change nothing.
  Status updateAtlas(const ImageRGBA8& image);
  Status updateAtlasRegion(uint32_t x, uint32_t y, uint32_t width, uint32_t height, const uint8_t* rgba8);

  // One frame, synchronously: record + submit and wait + collect, then the image read back. Call it
  // only with no recorded frame in flight (it uses slot 0).
  Result<RenderOutput> render(const AtlasClientSettings& settings);
  // Frames in flight, as ForwardRenderer's: record() uploads the pending patch and atlas changes and
  // records the frame into the caller's command buffer; the caller submits it with a fence of its
  // own and, once it signalled, collect(slot) gives the stats (no image: it is colorTarget()).
  // Frames run on one queue in the order recorded (each frame's first barrier orders it after the
  // earlier ones, which share the targets, the patch buffer and the atlas).
  Status record(VkCommandBuffer cmd, const AtlasClientSettings& settings, uint32_t slot);
  Result<RenderOutput> collect(uint32_t slot);
  // The colour target of the last recorded frame: RGBA16F linear, left in GENERAL with its writes
  // visible to compute shaders and transfers, as ForwardRenderer::colorTarget().
  const gpu::Image& colorTarget() const;

  struct Impl;

private:
  explicit AtlasClientRenderer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

} // namespace mirage::render
