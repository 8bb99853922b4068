#pragma once
// Shading Atlas Streaming, the server's work without the network (docs/stream.md, "Server"):
// StreamScene is what every client of one scene shares (the scene, its patches, the GPU stages);
// ClientStream is one client's state (its atlas allocation, the patches it holds, its atlas
// encoder). produceFrame answers one Pose with one Frame, in two halves:
//   prepareFrame (the GPU's): visibility (current + predicted view) -> level selection -> atlas
//   allocation -> shading of every visible patch's block -> colours of the patches that did not
//   fit -> the atlas read back (H.264: converted to YUV 4:2:0 on the GPU first)
//   finishFrame (the CPU's): atlas encoding -> the difference to what the client holds (removed,
//   added or moved patches, changed colours) in the Frame's patch section. A scene served with a
//   particle effect also streams its particles (particle_session.h): their looks take atlas blocks
//   beside the patches, and the Frame's particle section carries the visible particles.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "mirage/core/dense_id_map.h"
#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/gpu/context.h"
#include "mirage/render/atlas_shading.h"
#include "mirage/stream/atlas.h"
#include "mirage/stream/jpeg_tiles.h"
#include "mirage/stream/kept_patches.h"
#include "mirage/stream/link_budget.h"
#include "mirage/stream/particle_session.h"
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
  // Bits per axis of the position grid over the scene bounds (Welcome.positionStep): a position is off
  // by at most (largest extent) / 2^(bits + 1) per axis. 20 bits: 0.15 mm on the 320 m city, a tenth
  // of a 1080p pixel (60-degree fov) 2.5 m from the eye (docs/stream.md, "Patch section").
  uint32_t positionBits = 20;
  // How the server finds the visible patches (render/atlas_shading.h; docs/stream.md, "Visibility stage").
  render::AtlasVisibilityMethod visibility = render::AtlasVisibilityMethod::Auto;
  // A particle effect (.toml, docs/particles.md) streamed with the scene: every client's frames
  // carry its particles (docs/stream.md, "Particles"). Empty: none.
  std::string particles;
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
  float positionStep = 1.0f; // positionGridStep of the bounds
  // Some material is MASK or BLEND: the atlas's alpha matters. H.264 and JPEG carry no alpha, so
  // their images then stack the alpha below the colour (docs/stream.md, "Stacked alpha").
  bool translucent = false;
  // The particle effect and its looks (StreamSceneOptions::particles); each client simulates it.
  std::optional<particles::EffectFile> effect;
  std::optional<ParticleLooks> looks;
};

// Reads (or generates) the scene, tessellates its large triangles, builds its patches and uploads it.
// Errors name the input.
Result<std::unique_ptr<StreamScene>> openStreamScene(gpu::Context& context, const StreamSceneOptions& options);

// The Welcome of a client of `scene` served with `codec` (session id and server limits left 0).
Welcome sceneWelcome(const StreamScene& scene, AtlasCodec codec);

// The alpha mode of a global patch's material.
AlphaMode patchAlphaMode(const StreamScene& scene, uint32_t globalPatch);

// The render camera of a protocol camera (fov in radians -> degrees; clip planes from the scene).
render::Camera toRenderCamera(const Camera& camera, const Bounds& bounds);
Camera toProtocolCamera(const render::Camera& camera);

struct ClientStreamConfig {
  AtlasCodec codec = AtlasCodec::ZstdTiles; // ZstdTiles (lossless), H264 or JpegTiles (browsers)
  // H264: the rate control's target, for the whole frame (the link's bitrate: the video gets what
  // the patch and particle sections leave, LinkBudget) or, with linkBudget off, the video alone.
  uint32_t bitrateKbps = 20000;
  uint32_t fps = 60;      // H264: the frame rate the rate control assumes
  float levelBias = 0.0f; // patchBlockLog2's bias: > 0 more texels per pixel
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
  // The client decodes a zstd patch section (Hello's kCapabilityZstdPatches): frames use it when it
  // is smaller.
  bool zstdPatches = true;
  uint32_t encoderThreads = 0; // H264: x264's slice threads (VideoConfig::threads; 0: x264 picks)
  // Atlas blocks of streamed particles: one per look (texture merging) or one per visible particle.
  ParticlePatches particlePatches = ParticlePatches::Merged;
  bool linkBudget = true; // H264: bitrateKbps covers every section (stream/link_budget.h)
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
  uint32_t blockOnly = 0;     // of them without positions (the client's geometry at a new block)
  uint32_t removed = 0;
  uint32_t colours = 0;         // colours sent (colour-only patches new or changed)
  uint64_t shadedTexels = 0;    // atlas texels shaded (every visible block, every frame; particles' included)
  ParticleFrameStats particles; // particles visible, looks used, texels shaded for them
  float levelBias = 0.0f;       // the level bias used, after fitting the atlas (ClientStreamConfig::atlasFill)
  // The patch section (removed ids, entries, colours) as sent, and before zstd.
  uint64_t geometryBytes = 0, geometryRawBytes = 0;
  uint64_t particleBytes = 0, particleRawBytes = 0; // the particle section as sent, and before zstd
  uint64_t atlasBytes = 0;
  uint32_t videoTargetKbps = 0; // H264: the video's target for this frame (the link's share, LinkBudget)
  // Wall clock on the server: visibility; level selection, allocation and shading (blocks and
  // colour-only patches); the atlas read back (H.264: its conversion to YUV and the planes read back;
  // tile codecs: the RGBA8 image); the atlas codec (tile codecs: with stacking the alpha); the patch
  // section. totalMs: prepareFrame's and finishFrame's wall time (not the wait between them).
  double visibilityMs = 0, shadingMs = 0, readbackMs = 0, encodeMs = 0, patchesMs = 0, totalMs = 0;
  // Parts of shadingMs on the CPU: level selection (with fitting), atlas allocation, the block and
  // colour-only lists.
  double levelsMs = 0, allocateMs = 0, blocksMs = 0;
  // GPU time (timestamp queries): the visibility passes; clearing, shading the blocks and the
  // colour-only patches; the YUV conversion (H.264).
  double gpuVisibilityMs = 0, gpuShadingMs = 0, gpuConvertMs = 0;
  // Every timed pass: the stages above and their parts, named "stage.part" (e.g. "visibility.mark").
  std::vector<gpu::PassTime> gpuPasses;
};

class ClientStream {
public:
  // Errors: a codec other than ZstdTiles or H264, an encoder that cannot start.
  static Result<std::unique_ptr<ClientStream>> create(const StreamScene& scene, const ClientStreamConfig& config);

  // The Frame answering `pose`: prepareFrame then finishFrame. Errors (a GPU stage or the encoder
  // failing) leave what the client holds as it was: the next frame starts from there.
  Result<Frame> produceFrame(StreamScene& scene, const Pose& pose, StreamFrameStats* stats = nullptr);
  // The GPU half: needs the scene's GPU stages to itself (one thread prepares, for every client).
  // The atlas it reads back is this client's (its YUV image or RGBA copy), so the GPU may go on to
  // the next client while this one finishes. Errors: an empty viewport, a GPU stage failing.
  Status prepareFrame(StreamScene& scene, const Pose& pose);
  // The CPU half, on any thread (no GPU; the scene is only read): encodes the atlas prepareFrame
  // read back and writes the patch section. Each prepareFrame is followed by one finishFrame before
  // the next. Errors: nothing prepared, the encoder failing.
  Result<Frame> finishFrame(const StreamScene& scene, StreamFrameStats* stats = nullptr);
  // The next atlas payload carries the whole atlas (a client that lost frames).
  void requestKeyframe();
  const ClientStreamConfig& config() const { return config_; }

private:
  ClientStream(const ClientStreamConfig& config, AtlasAllocator atlas);
  // Fills frame's patch section with what changed against what the client holds, and makes the
  // result what it holds (the last step of produceFrame: nothing after it fails).
  void diffPatches(const StreamScene& scene, const std::vector<std::pair<uint32_t, AtlasPlacement>>& placed,
                   const std::vector<uint32_t>& colourOnly, const std::vector<uint32_t>& keptColourOnly,
                   const std::vector<glm::u8vec4>& colours, Frame& frame, StreamFrameStats& st);

  // What the client holds of a patch: its block, or colour-only with the colour last sent.
  struct Held {
    std::optional<AtlasPlacement> block;
    std::optional<std::array<uint8_t, 4>> colour;
  };
  struct Nothing {}; // what the server keeps of a removed patch: the scene has its geometry
  // What prepareFrame leaves for finishFrame.
  struct Prepared {
    uint32_t poseSequence = 0;
    std::vector<std::pair<uint32_t, AtlasPlacement>> placed; // by id
    std::vector<uint32_t> colourOnly, keptColourOnly;
    std::vector<glm::u8vec4> colours; // of colourOnly
    ImageRGBA8 atlas;                 // tile codecs: the atlas read back (H.264: yuv_)
    StreamFrameStats stats;
  };
  ClientStreamConfig config_;
  AtlasAllocator atlas_;
  std::optional<TileDeltaEncoder> tiles_;
  std::optional<VideoEncoder> video_;
  std::optional<LinkBudget> link_; // H264 with linkBudget: the video's share of the link
  std::optional<JpegTileEncoder> jpeg_;
  bool stackedAlpha_ = false;    // images twice the atlas height: alpha below the colour
  render::AtlasYuvImage yuv_;    // H.264: the atlas as the encoder takes it (stacked alpha included)
  std::vector<uint8_t> stacked_; // JPEG tiles with stacked alpha: that image
  std::optional<Prepared> prepared_;
  bool keyframe_ = true;
  std::unique_ptr<ClientParticles> particles_; // with an effect
  DenseIdMap<Held> held_;
  DenseIdMap<Held> next_;            // diffPatches' next held_, kept for its index
  KeptPatches<Nothing> kept_;        // the client's kept geometry, mirrored
  DenseIdMap<uint32_t> lastVisible_; // held patch -> the frame it was last visible in
  uint32_t sequence_ = 0;
};

} // namespace mirage::stream
