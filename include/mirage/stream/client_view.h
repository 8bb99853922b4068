#pragma once
// Shading Atlas Streaming, the client's side without the network (docs/stream.md, "Client"): the
// patches and the atlas a server sent, kept and drawn from any camera at the client's own frame
// rate (between server frames the latest atlas serves every new view: frame-rate upsampling).
#include <cstdint>
#include <memory>
#include <optional>
#include <unordered_map>

#include "mirage/core/result.h"
#include "mirage/gpu/context.h"
#include "mirage/render/atlas_client.h"
#include "mirage/stream/jpeg_tiles.h"
#include "mirage/stream/kept_patches.h"
#include "mirage/stream/protocol.h"
#include "mirage/stream/tile_codec.h"
#include "mirage/stream/video.h"

namespace mirage::stream {

class StreamView {
public:
  // The renderer and the decoder for the atlas size and codec `welcome` names.
  static Result<std::unique_ptr<StreamView>> create(gpu::Context& context, const Welcome& welcome);

  // Applies the connection's next server frame: removed patches (their geometry kept for
  // kKeptGeometryFrames frames), added patches and new blocks, colours, the particles (the frame's
  // looks, then its particles, each drawn with its look's block or colour; the looks no particle of
  // the frame uses are dropped), the atlas. Errors (a patch id past the scene's, a removal of a patch
  // not held, positions for a patch held, a block-only entry for geometry the client does not have,
  // a colour for a patch not held as colour-only, a particle of a look the client does not hold, a
  // look's block outside the atlas, an atlas payload that does not decode) name the frame; the
  // caller closes the connection (its state may be partly applied).
  Status apply(const Frame& frame);

  // Draws the patches held from `camera` (clip planes from the scene bounds when zero).
  Result<render::RenderOutput> render(const render::Camera& camera, uint32_t width, uint32_t height,
                                      bool readLinear = false);

  size_t patchCount() const { return patches_.size(); }
  size_t keptCount() const { return kept_.size(); } // removed patches whose geometry is kept
  size_t particleCount() const { return renderer_->particleCount(); }
  size_t lookCount() const { return looks_.size(); } // particle looks held (used by the last frame)
  const Welcome& welcome() const { return welcome_; }
  render::AtlasClientRenderer& renderer() { return *renderer_; }
  // Uploads a decoded image: the atlas, or the atlas with its alpha stacked below (twice the height).
  Status uploadAtlas(const std::vector<uint8_t>& rgba, uint32_t width, uint32_t height);

private:
  StreamView() = default;
  Status applyParticles(const Frame& frame);
  Welcome welcome_;
  Bounds bounds_;
  std::unique_ptr<render::AtlasClientRenderer> renderer_;
  std::optional<TileDeltaDecoder> tiles_;
  std::optional<VideoDecoder> video_;
  std::optional<JpegTileDecoder> jpeg_; // made by the first payload (its height says: stacked alpha or not)
  std::unordered_map<uint32_t, render::ClientPatch> patches_;
  KeptPatches<render::ClientPatch> kept_;
  // A particle look as the client holds it: its block, or its colour (ClientParticle's fields).
  struct Look {
    bool colorOnly = false;
    uint32_t blockX = 0, blockY = 0, blockLog2 = 1, color = 0;
  };
  std::unordered_map<uint32_t, Look> looks_;
  uint32_t frames_ = 0; // frames applied
};

} // namespace mirage::stream
