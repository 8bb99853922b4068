// The client's kept state and drawing (client_view.h; docs/stream.md, "Client").
#include "mirage/stream/client_view.h"

#include <fmt/format.h>

#include "mirage/render/camera.h"

namespace mirage::stream {

Result<std::unique_ptr<StreamView>> StreamView::create(gpu::Context& context, const Welcome& welcome) {
  std::unique_ptr<StreamView> v(new StreamView());
  v->welcome_ = welcome;
  v->bounds_.add(welcome.sceneMin);
  v->bounds_.add(welcome.sceneMax);
  render::AtlasClientConfig config;
  config.atlasWidth = welcome.atlasWidth;
  config.atlasHeight = welcome.atlasHeight;
  config.maxPatches = std::max(1u, welcome.patchCount);
  auto renderer = render::AtlasClientRenderer::create(context, config);
  if (!renderer) return renderer.error();
  v->renderer_ = std::move(*renderer);
  if (welcome.codec == AtlasCodec::ZstdTiles) {
    v->tiles_.emplace();
  } else if (welcome.codec == AtlasCodec::H264) {
    auto video = VideoDecoder::create();
    if (!video) return video.error();
    v->video_.emplace(std::move(*video));
  } else if (welcome.codec != AtlasCodec::None && welcome.codec != AtlasCodec::JpegTiles) {
    return Error{fmt::format("Welcome: atlas codec {} is not supported by this client", int(welcome.codec))};
  }
  return v;
}

namespace {

render::PatchAlpha toPatchAlpha(AlphaMode mode) {
  return mode == AlphaMode::Blend  ? render::PatchAlpha::Blend
         : mode == AlphaMode::Mask ? render::PatchAlpha::Mask
                                   : render::PatchAlpha::Opaque;
}

uint32_t packColour(const std::array<uint8_t, 4>& c) {
  return uint32_t(c[0]) | uint32_t(c[1]) << 8 | uint32_t(c[2]) << 16 | uint32_t(c[3]) << 24;
}

} // namespace

Status StreamView::apply(const Frame& frame) {
  auto fail = [&](const std::string& what) { return Error{fmt::format("Frame {}: {}", frame.sequence, what)}; };
  kept_.beginFrame(++frames_);
  for (uint32_t id : frame.removed) {
    auto it = patches_.find(id);
    if (it == patches_.end()) return fail(fmt::format("removes patch {}, which the client does not hold", id));
    if (auto s = renderer_->removePatch(id); !s) return fail(s.error().message);
    kept_.keep(id, it->second);
    patches_.erase(it);
  }
  for (const PatchUpdate& u : frame.updated) {
    if (u.id >= welcome_.patchCount)
      return fail(fmt::format("patch {} is past the scene's {} patches", u.id, welcome_.patchCount));
    render::ClientPatch p;
    auto held = patches_.find(u.id);
    if (u.geometry) {
      if (held != patches_.end())
        return fail(fmt::format("sends the positions of patch {}, which the client holds", u.id));
      kept_.take(u.id); // sent again: the kept copy is stale
      p.triangleCount = u.triangleCount;
      for (uint32_t v = 0; v < patchVertexCount(u.triangleCount); ++v)
        p.positions[v] = dequantizePosition(u.positions[v], welcome_.sceneMin, welcome_.positionStep);
      p.alpha = toPatchAlpha(u.alpha);
    } else if (held != patches_.end()) {
      p = held->second;
    } else if (auto kept = kept_.take(u.id)) {
      p = *kept;
    } else {
      return fail(fmt::format("block-only entry for patch {}, whose geometry the client does not have", u.id));
    }
    if (p.triangleCount != u.triangleCount)
      return fail(fmt::format("patch {} has {} triangles, the entry says {}", u.id, p.triangleCount, u.triangleCount));
    p.colorOnly = u.blockLog2 == kColourOnlyBlock;
    p.blockX = p.colorOnly ? 0 : u.blockX;
    p.blockY = p.colorOnly ? 0 : u.blockY;
    p.blockLog2 = p.colorOnly ? 1 : u.blockLog2;
    p.color = 0; // a new block or colour-only: its colour (if any) comes in this frame's colours
    if (auto s = renderer_->setPatch(u.id, p); !s) return fail(s.error().message);
    patches_[u.id] = p;
  }
  for (const PatchColour& c : frame.colours) {
    auto it = patches_.find(c.id);
    if (it == patches_.end() || !it->second.colorOnly)
      return fail(fmt::format("colour for patch {}, which the client does not hold as colour-only", c.id));
    it->second.color = packColour(c.rgba);
    if (auto s = renderer_->setPatch(c.id, it->second); !s) return fail(s.error().message);
  }
  if (auto s = applyParticles(frame); !s) return fail(s.error().message);
  if (frame.atlas.codec == AtlasCodec::None) return Ok{};
  if (frame.atlas.codec != welcome_.codec)
    return fail(
        fmt::format("atlas codec {} differs from the session's {}", int(frame.atlas.codec), int(welcome_.codec)));
  if (tiles_) {
    if (auto s = tiles_->decode(frame.atlas.bytes); !s) return fail(s.error().message);
    if (tiles_->width() != welcome_.atlasWidth || tiles_->height() != welcome_.atlasHeight)
      return fail("atlas size differs from Welcome's");
    ImageRGBA8 image{tiles_->width(), tiles_->height(), tiles_->image()};
    if (auto s = renderer_->updateAtlas(image); !s) return fail(s.error().message);
  } else if (video_) {
    auto out = video_->decode(frame.atlas.bytes);
    if (!out) return fail(out.error().message);
    if (*out)
      if (auto s = uploadAtlas(video_->image(), video_->width(), video_->height()); !s) return fail(s.error().message);
  } else if (welcome_.codec == AtlasCodec::JpegTiles) {
    auto header = readJpegTilesHeader(frame.atlas.bytes, "atlas");
    if (!header) return fail(header.error().message);
    if (!jpeg_ || header->keyframe()) jpeg_.emplace(header->width, header->height);
    if (auto s = jpeg_->decode(frame.atlas.bytes, "atlas"); !s) return fail(s.error().message);
    if (auto s = uploadAtlas(jpeg_->rgba(), header->width, header->height); !s) return fail(s.error().message);
  }
  return Ok{};
}

Status StreamView::applyParticles(const Frame& frame) {
  for (const ParticleLook& l : frame.looks) {
    Look look;
    look.colorOnly = l.blockLog2 == kColourOnlyBlock;
    if (look.colorOnly) {
      look.color = packColour(l.rgba);
    } else {
      look.blockX = l.blockX, look.blockY = l.blockY, look.blockLog2 = l.blockLog2;
      uint64_t side = 1u << l.blockLog2;
      if (l.blockX + 2 * side > welcome_.atlasWidth || l.blockY + side > welcome_.atlasHeight)
        return Error{fmt::format("look {}: block {}x{} at ({}, {}) outside the {}x{} atlas", l.id, 2 * side, side,
                                 l.blockX, l.blockY, welcome_.atlasWidth, welcome_.atlasHeight)};
    }
    looks_[l.id] = look;
  }
  std::unordered_map<uint32_t, Look> used;
  std::vector<render::ClientParticle> particles;
  particles.reserve(frame.particles.size());
  for (size_t i = 0; i < frame.particles.size(); ++i) {
    const StreamParticle& p = frame.particles[i];
    auto look = looks_.find(p.look);
    if (look == looks_.end())
      return Error{fmt::format("particle {} of look {}, which the client does not hold", i, p.look)};
    used.emplace(p.look, look->second);
    render::ClientParticle c;
    c.position = particlePosition(p, frame.particleOrigin, frame.particleStep);
    c.size = particleSize(p.size);
    c.rotation = particleRotation(p.rotation);
    c.color = packColour(p.rgba);
    c.colorOnly = look->second.colorOnly;
    c.blockX = look->second.blockX, c.blockY = look->second.blockY, c.blockLog2 = look->second.blockLog2;
    c.lookColor = look->second.color;
    particles.push_back(c);
    bounds_.add(c.position - glm::vec3(c.size)); // the clip planes take every particle in
    bounds_.add(c.position + glm::vec3(c.size));
  }
  if (auto s = renderer_->setParticles(particles); !s) return s;
  looks_ = std::move(used); // what a later frame's particles may refer to without an entry
  return Ok{};
}

Status StreamView::uploadAtlas(const std::vector<uint8_t>& rgba, uint32_t width, uint32_t height) {
  // Colour alone, or colour on top and alpha below as grey (a scene with MASK or BLEND materials
  // sent through a codec without alpha: docs/stream.md, "Stacked alpha").
  uint32_t w = welcome_.atlasWidth, h = welcome_.atlasHeight;
  bool stacked = height == 2 * h;
  if (width != w || (height != h && !stacked))
    return Error{fmt::format("a {}x{} image for a {}x{} atlas", width, height, w, h)};
  size_t texels = size_t(w) * h;
  ImageRGBA8 image{w, h, std::vector<uint8_t>(rgba.begin(), rgba.begin() + std::ptrdiff_t(texels * 4))};
  if (stacked)
    for (size_t i = 0; i < texels; ++i) image.pixels[i * 4 + 3] = rgba[(texels + i) * 4];
  return renderer_->updateAtlas(image);
}

Result<render::RenderOutput> StreamView::render(const render::Camera& camera, uint32_t width, uint32_t height,
                                                bool readLinear) {
  render::AtlasClientSettings settings;
  settings.width = width;
  settings.height = height;
  settings.camera = render::withClipPlanes(camera, bounds_);
  settings.readLinear = readLinear;
  return renderer_->render(settings);
}

} // namespace mirage::stream
