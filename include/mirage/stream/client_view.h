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
#include "mirage/stream/protocol.h"
#include "mirage/stream/tile_codec.h"
#include "mirage/stream/video.h"

namespace mirage::stream {

class StreamView {
public:
  // The renderer and the decoder for the atlas size and codec `welcome` names.
  static Result<std::unique_ptr<StreamView>> create(gpu::Context& context, const Welcome& welcome);

  // Applies a server frame: removed patches, added or moved ones, colours, the atlas. Errors (a
  // patch id past the scene's, a colour for a patch the client does not hold, an atlas payload
  // that does not decode) name the frame; the caller closes the connection (its state may be
  // partly applied).
  Status apply(const Frame& frame);

  // Draws the patches held from `camera` (clip planes from the scene bounds when zero).
  Result<render::RenderOutput> render(const render::Camera& camera, uint32_t width, uint32_t height,
                                      bool readLinear = false);

  size_t patchCount() const { return patches_.size(); }
  const Welcome& welcome() const { return welcome_; }
  render::AtlasClientRenderer& renderer() { return *renderer_; }
  // Uploads a decoded image: the atlas, or the atlas with its alpha stacked below (twice the height).
  Status uploadAtlas(const std::vector<uint8_t>& rgba, uint32_t width, uint32_t height);

private:
  StreamView() = default;
  Welcome welcome_;
  Bounds bounds_;
  std::unique_ptr<render::AtlasClientRenderer> renderer_;
  std::optional<TileDeltaDecoder> tiles_;
  std::optional<VideoDecoder> video_;
  std::optional<JpegTileDecoder> jpeg_; // made by the first payload (its height says: stacked alpha or not)
  std::unordered_map<uint32_t, render::ClientPatch> patches_;
};

} // namespace mirage::stream
