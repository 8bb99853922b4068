#pragma once
// Shading Atlas Streaming, the server's work without the network (docs/stream.md, "Server"):
// StreamScene is what every client of one scene shares (the scene, its patches, the GPU stages);
// ClientStream is one client's state (its atlas allocation, the patches it holds, its atlas
// encoder). produceFrame answers one Pose with one Frame:
//   visibility (current + predicted view) -> level selection -> atlas allocation -> shading of
//   every visible patch's block -> colours of the patches that did not fit -> atlas encoding ->
//   the difference to what the client holds (removed, added or moved patches).
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/gpu/context.h"
#include "mirage/render/atlas_shading.h"
#include "mirage/stream/atlas.h"
#include "mirage/stream/jpeg_tiles.h"
#include "mirage/stream/patches.h"
#include "mirage/stream/protocol.h"
#include "mirage/stream/tessellate.h"
#include "mirage/stream/tile_codec.h"
#include "mirage/stream/video.h"

namespace mirage::stream {

struct StreamSceneOptions {
  std::string input;         // a scene file (.gltf .glb .obj .ply) or gen:KIND[:SIZE[:SEED]]
  std::string materials;     // optional material file (TOML) applied after import
  uint32_t atlasSize = 2048; // atlas side in texels (a power of two, 128..16384)
  // Large triangles split before patches are built (tessellate.h).
  TessellationConfig tessellation;
};

// What every client of a scene shares. The GPU atlas is scratch: each frame produced clears it and
// shades that client's visible blocks before reading it back, so clients never see each other's.
struct StreamScene {
  Scene scene; // tessellated (tessellate.h)
  TessellationStats tessellation;
  PatchTable patches;
  std::vector<uint32_t> meshFirstVertex; // render::atlasMeshFirstVertex
  std::unique_ptr<render::AtlasShading> shading;
  render::AtlasLighting lighting;
  Bounds bounds;
  uint32_t atlasSize = 0;
  // Some material is MASK or BLEND: the atlas's alpha matters. H.264 and JPEG carry no alpha, so
  // their images then stack the alpha below the colour (docs/stream.md, "Stacked alpha").
  bool translucent = false;
};

// Reads (or generates) the scene, tessellates its large triangles, builds its patches and uploads it.
// Errors name the input.
Result<std::unique_ptr<StreamScene>> openStreamScene(gpu::Context& context, const StreamSceneOptions& options);

// The alpha mode of a global patch's material.
AlphaMode patchAlphaMode(const StreamScene& scene, uint32_t globalPatch);

// The render camera of a protocol camera (fov in radians -> degrees; clip planes from the scene).
render::Camera toRenderCamera(const Camera& camera, const Bounds& bounds);
Camera toProtocolCamera(const render::Camera& camera);

struct ClientStreamConfig {
  AtlasCodec codec = AtlasCodec::ZstdTiles; // ZstdTiles (lossless), H264 or JpegTiles (browsers)
  uint32_t bitrateKbps = 20000;             // H264: the rate control's target
  uint32_t fps = 60;                        // H264: the frame rate the rate control assumes
  float levelBias = 0.0f;                   // patchBlockLog2's bias: > 0 more texels per pixel
  // Frames a patch stays with the client (and keeps its block, shaded every frame) after it was
  // last visible. Small patches flicker in and out of the visibility buffer from frame to frame;
  // without this each flicker costs a removal and a re-send of the patch (docs/stream.md, "Server").
  uint32_t keepInvisibleFrames = 8;
  // Share of the atlas the visible patches' blocks may want. When they would want more, the level
  // bias is lowered for every patch alike (fitLevelBias, in quarter levels) instead of the largest
  // patches taking the atlas and the rest getting one colour each. The rest is room for kept
  // patches, blocks up to one level above their wanted level (the allocator's hysteresis) and
  // partly used superblocks (docs/stream.md, "Fitting the atlas"). 0: no fitting.
  float atlasFill = 0.5f;
};

// H.264 carries colour at half resolution (4:2:0; the encoder averages each 2x2 texel square so no
// colour crosses a block border), which blurs texel-sized detail: a 2-texel block becomes one
// colour. H.264 sessions therefore ask for blocks twice the side (bias + 1), which keeps colour at
// one sample per pixel. Measured on gen:city:2 at 320x180 (lossless atlas as reference): bias 0 gives
// PSNR 29.7 dB / SSIM 0.916 at any bitrate, bias 1 60 dB / 1.000, for 12 % more bytes.
constexpr float kH264LevelBias = 1.0f;

// What one frame cost, for --stats and benchmarks.
struct StreamFrameStats {
  uint32_t visiblePatches = 0;
  uint32_t placedPatches = 0; // visible with a block
  uint32_t colourOnly = 0;    // visible without one (atlas full)
  uint32_t addedOrMoved = 0;  // PatchUpdates sent
  uint32_t removed = 0;
  uint64_t shadedTexels = 0;  // atlas texels shaded (every visible block, every frame)
  float levelBias = 0.0f;     // the level bias used, after fitting the atlas (ClientStreamConfig::atlasFill)
  uint64_t geometryBytes = 0; // removed + updated entries as encoded
  uint64_t colourBytes = 0;
  uint64_t atlasBytes = 0;
  double visibilityMs = 0, shadingMs = 0, encodeMs = 0, totalMs = 0; // wall clock on the server
  // GPU time (timestamp queries): the visibility passes; clearing, shading the blocks and the
  // colour-only patches. The atlas readback (a copy to host memory) is in shadingMs only.
  double gpuVisibilityMs = 0, gpuShadingMs = 0;
};

class ClientStream {
public:
  // Errors: a codec other than ZstdTiles or H264, an encoder that cannot start.
  static Result<std::unique_ptr<ClientStream>> create(const StreamScene& scene, const ClientStreamConfig& config);

  // The Frame answering `pose`. Errors (a GPU stage or the encoder failing) leave the client's
  // state as it was: the next frame starts from what the client holds.
  Result<Frame> produceFrame(StreamScene& scene, const Pose& pose, StreamFrameStats* stats = nullptr);
  // The next atlas payload carries the whole atlas (a client that lost frames).
  void requestKeyframe();
  const ClientStreamConfig& config() const { return config_; }

private:
  ClientStream(const ClientStreamConfig& config, AtlasAllocator atlas);

  // What the client holds of a patch: its block, or colour-only.
  struct Held {
    std::optional<AtlasPlacement> block;
  };
  ClientStreamConfig config_;
  AtlasAllocator atlas_;
  std::optional<TileDeltaEncoder> tiles_;
  std::optional<VideoEncoder> video_;
  std::optional<JpegTileEncoder> jpeg_;
  bool stackedAlpha_ = false;    // images twice the atlas height: alpha below the colour
  std::vector<uint8_t> stacked_; // that image
  bool keyframe_ = true;
  std::unordered_map<uint32_t, Held> held_;
  uint32_t sequence_ = 0;
};

} // namespace mirage::stream
