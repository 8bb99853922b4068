// The server's frame production (session.h; docs/stream.md, "Server").
#include "mirage/stream/session.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "mirage/particles/effect.h"
#include "mirage/runtime/scene_argument.h"
#include "mirage/shading/material_file.h"

namespace mirage::stream {

namespace {

using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

uint64_t microsecondsNow() {
  return uint64_t(
      std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch())
          .count());
}

// Largest number of blocks one shade() call takes: the shading stage's buffers are sized by it,
// larger frames shade in several calls.
constexpr uint32_t kMaxPatchesPerShade = 1u << 18;

} // namespace

Result<std::unique_ptr<StreamScene>> openStreamScene(gpu::Context& context, const StreamSceneOptions& options) {
  if (options.atlasSize < 128 || options.atlasSize > 16384 || (options.atlasSize & (options.atlasSize - 1)))
    return Error{fmt::format("--atlas-size {} must be a power of two in 128..16384", options.atlasSize)};
  if (options.positionBits < 8 || options.positionBits > kPositionGridBits)
    return Error{fmt::format("--position-bits {} must be in 8..{}", options.positionBits, kPositionGridBits)};
  std::optional<particles::EffectFile> effect;
  if (!options.particles.empty()) { // read first too
    auto file = particles::loadEffectFile(options.particles);
    if (!file) return file.error();
    effect = std::move(*file);
  }
  std::optional<shading::MaterialFile> materials;
  if (!options.materials.empty()) { // read first: a bad material file costs no import
    auto file = shading::loadMaterialFile(options.materials);
    if (!file) return file.error();
    materials = std::move(*file);
  }
  auto scene = runtime::loadSceneArgument(options.input);
  if (!scene) return scene.error();
  auto s = std::make_unique<StreamScene>();
  s->scene = std::move(*scene);
  if (materials)
    if (auto st = shading::applyMaterials(s->scene, *materials); !st) return st.error();
  if (s->scene.instancedTriangleCount() == 0) return Error{fmt::format("{}: no triangles to stream", options.input)};
  auto tessellation = tessellateScene(s->scene, options.tessellation);
  if (!tessellation) return makeError(options.input, tessellation.error().message);
  s->tessellation = *tessellation;
  s->patches = buildPatchTable(s->scene);
  std::vector<uint32_t> patchOfTriangle(s->patches.triangleCount());
  for (uint32_t t = 0; t < patchOfTriangle.size(); ++t) patchOfTriangle[t] = s->patches.patchOfTriangle(t);
  render::AtlasShadingConfig config;
  config.atlasSide = options.atlasSize;
  config.maxPatches = std::min(s->patches.patchCount(), kMaxPatchesPerShade);
  config.visibility = options.visibility;
  auto shading = render::AtlasShading::create(context, s->scene, std::move(patchOfTriangle), config);
  if (!shading) return makeError(options.input, shading.error().message);
  s->shading = std::move(*shading);
  s->meshFirstVertex = render::atlasMeshFirstVertex(s->scene);
  s->bounds = s->scene.worldBounds();
  s->atlasSize = options.atlasSize;
  s->positionStep = positionGridStep(s->bounds.min, s->bounds.max, options.positionBits);
  for (const Material& m : s->scene.materials) s->translucent |= m.alphaMode != mirage::AlphaMode::Opaque;
  if (effect) {
    auto looks = ParticleLooks::build(*effect);
    if (!looks) return looks.error();
    s->looks = std::move(*looks);
    s->effect = std::move(effect);
    s->translucent = true; // particle looks carry coverage in their alpha
  }
  return s;
}

Welcome sceneWelcome(const StreamScene& scene, AtlasCodec codec) {
  Welcome w;
  w.sceneMin = scene.bounds.min;
  w.sceneMax = scene.bounds.max;
  w.positionStep = scene.positionStep;
  w.atlasWidth = w.atlasHeight = scene.atlasSize;
  w.codec = codec;
  w.patchCount = scene.patches.patchCount();
  return w;
}

AlphaMode patchAlphaMode(const StreamScene& scene, uint32_t globalPatch) {
  PatchRef ref = scene.patches.patchRef(globalPatch);
  const Mesh& mesh = scene.scene.meshes[scene.patches.instanceMesh[ref.instance]];
  if (mesh.material >= scene.scene.materials.size()) return AlphaMode::Opaque;
  switch (scene.scene.materials[mesh.material].alphaMode) {
  case mirage::AlphaMode::Mask:
    return AlphaMode::Mask;
  case mirage::AlphaMode::Blend:
    return AlphaMode::Blend;
  default:
    return AlphaMode::Opaque;
  }
}

render::Camera toRenderCamera(const Camera& camera, const Bounds& bounds) {
  render::Camera c;
  c.eye = camera.eye;
  c.target = camera.target;
  c.up = camera.up;
  c.fovYDegrees = glm::degrees(camera.fovY);
  return render::withClipPlanes(c, bounds);
}

Camera toProtocolCamera(const render::Camera& camera) {
  return {camera.eye, camera.target, camera.up, glm::radians(camera.fovYDegrees)};
}

ClientStream::ClientStream(const ClientStreamConfig& config, AtlasAllocator atlas)
    : config_(config), atlas_(std::move(atlas)) {}

Result<std::unique_ptr<ClientStream>> ClientStream::create(const StreamScene& scene, const ClientStreamConfig& config) {
  AtlasConfig ac;
  ac.size = scene.atlasSize;
  ac.keepInvisibleFrames = config.keepInvisibleFrames;
  auto atlas = AtlasAllocator::create(ac);
  if (!atlas) return atlas.error();
  std::unique_ptr<ClientStream> c(new ClientStream(config, std::move(*atlas)));
  if (config.codec == AtlasCodec::ZstdTiles) {
    c->tiles_.emplace(scene.atlasSize, scene.atlasSize);
  } else if (config.codec == AtlasCodec::H264) {
    VideoConfig vc;
    vc.width = scene.atlasSize;
    vc.height = scene.translucent ? 2 * scene.atlasSize : scene.atlasSize;
    c->stackedAlpha_ = scene.translucent;
    vc.fps = config.fps;
    vc.bitrateKbps = config.bitrateKbps;
    vc.threads = config.encoderThreads;
    auto video = VideoEncoder::create(vc);
    if (!video) return video.error();
    c->video_.emplace(std::move(*video));
    if (config.linkBudget) c->link_.emplace(LinkBudgetConfig{config.bitrateKbps, config.fps});
    c->yuv_ = scene.shading->createYuvImage(scene.translucent);
  } else if (config.codec == AtlasCodec::JpegTiles) {
    c->stackedAlpha_ = scene.translucent;
    c->jpeg_.emplace(scene.atlasSize, scene.translucent ? 2 * scene.atlasSize : scene.atlasSize);
  } else {
    return Error{fmt::format("atlas codec {} is not served", int(config.codec))};
  }
  if (scene.effect) c->particles_ = std::make_unique<ClientParticles>(*scene.effect, config.particlePatches);
  return c;
}

void ClientStream::requestKeyframe() {
  keyframe_ = true;
  if (tiles_) tiles_->requestKeyframe();
  if (jpeg_) jpeg_->requestKeyframe();
}

Result<Frame> ClientStream::produceFrame(StreamScene& scene, const Pose& pose, StreamFrameStats* stats) {
  if (Status s = prepareFrame(scene, pose); !s) return s.error();
  return finishFrame(scene, stats);
}

Status ClientStream::prepareFrame(StreamScene& scene, const Pose& pose) {
  prepared_.reset();
  Prepared p;
  StreamFrameStats& st = p.stats;
  p.poseSequence = pose.sequence;
  auto t0 = Clock::now();
  const uint32_t w = pose.viewportWidth, h = pose.viewportHeight;
  if (w == 0 || h == 0) return Error{"Pose: empty viewport"};
  render::Camera cameras[2] = {toRenderCamera(pose.camera, scene.bounds), toRenderCamera(pose.predicted, scene.bounds)};
  scene.shading->takePassTimes(); // this frame's only
  auto visible = scene.shading->visibility(cameras, w, h);
  if (!visible) return visible.error();
  st.visibilityMs = msSince(t0);
  st.visiblePatches = uint32_t(visible->size());
  const uint32_t frameNumber = sequence_ + 1;
  for (uint32_t id : *visible) lastVisible_[id] = frameNumber;

  // Particles: the simulation at this frame, the particles either view sees, their looks.
  const float aspect = float(w) / float(h);
  const uint32_t firstLook = scene.patches.patchCount(); // look l's atlas id: firstLook + l
  if (particles_) {
    ParticleView views[2];
    for (int i = 0; i < 2; ++i) views[i] = {cameras[i].view(), cameras[i].projection(aspect), float(h)};
    particles_->prepare(*scene.looks, frameNumber, views);
  }

  // Level selection: the larger block either view wants, the bias lowered alike for every patch
  // (and particle look) when their blocks would not fit the atlas share (ClientStreamConfig::atlasFill).
  auto tShade = Clock::now();
  float bias = config_.levelBias + (config_.codec == AtlasCodec::H264 ? kH264LevelBias : 0.0f);
  glm::mat4 viewProj[2];
  for (int i = 0; i < 2; ++i) viewProj[i] = cameras[i].projection(aspect) * cameras[i].view();
  // In parallel: tens of thousands of patches, each transformed and projected twice, on the
  // thread that feeds the GPU (the frame workers encode meanwhile).
  std::vector<PatchExtent> extents(visible->size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, visible->size(), 1024), [&](const tbb::blocked_range<size_t>& r) {
    glm::vec3 world[MIRAGE_ATLAS_MAX_PATCH_VERTICES];
    for (size_t k = r.begin(); k != r.end(); ++k) {
      const uint32_t id = (*visible)[k];
      PatchExtent e{0.0f, scene.patches.patch(scene.patches.patchRef(id)).triangleCount};
      patchWorldPositions(scene.scene, scene.patches, id, world);
      for (int i = 0; i < 2; ++i)
        e.length = std::max(e.length, patchProjectedLength(world, e.triangleCount, viewProj[i], {w, h}));
      extents[k] = e;
    }
  });
  if (particles_) particles_->appendExtents(bias, extents);
  if (config_.atlasFill > 0.0f)
    bias = fitLevelBias(extents, bias, uint64_t(double(config_.atlasFill) * scene.atlasSize * scene.atlasSize));
  st.levelBias = bias;
  st.levelsMs = msSince(tShade);
  auto tAllocate = Clock::now();
  std::vector<AtlasRequest> requests;
  requests.reserve(extents.size());
  for (size_t k = 0; k < visible->size(); ++k)
    requests.push_back({(*visible)[k], extents[k].triangleCount,
                        blockLog2ForLength(extents[k].length, extents[k].triangleCount, bias)});
  if (particles_) particles_->appendRequests(firstLook, bias, requests);
  atlas_.update(requests);
  st.allocateMs = msSince(tAllocate);
  auto tBlocks = Clock::now();

  // Shading: every block the client holds (visible, or kept a few frames after it was last seen),
  // every frame: view-dependent terms follow the eye, and a kept patch may be seen again client-side.
  p.placed = atlas_.placements();
  std::erase_if(p.placed, [&](const auto& e) { return e.first >= firstLook; }); // particle looks: below
  std::sort(p.placed.begin(), p.placed.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<shaderio::GpuAtlasPatch> blocks;
  blocks.reserve(p.placed.size());
  for (const auto& [id, block] : p.placed) {
    PatchRef ref = scene.patches.patchRef(id);
    uint32_t mesh = scene.patches.instanceMesh[ref.instance];
    const Patch& patch = scene.patches.patch(ref);
    blocks.push_back(
        gpuAtlasPatch(patch, scene.meshFirstVertex[mesh], ref.instance, scene.scene.meshes[mesh].material, block));
    st.shadedTexels += uint64_t(block.width()) * block.height();
  }
  for (uint32_t id : *visible)
    if (!atlas_.placement(id)) p.colourOnly.push_back(id);
  // Colour-only patches stay with the client keepInvisibleFrames frames after they were last
  // visible, as placed ones keep their blocks; they keep the colour last sent.
  for (const auto& [id, held] : held_) {
    if (held.block || atlas_.placement(id)) continue;
    const uint32_t seen = lastVisible_[id];
    if (seen != frameNumber && frameNumber - seen <= config_.keepInvisibleFrames) p.keptColourOnly.push_back(id);
  }
  st.placedPatches = uint32_t(blocks.size());
  st.colourOnly = uint32_t(p.colourOnly.size());
  st.blocksMs = msSince(tBlocks);
  scene.shading->clearAtlas();
  for (size_t first = 0; first < blocks.size(); first += kMaxPatchesPerShade) {
    size_t count = std::min<size_t>(kMaxPatchesPerShade, blocks.size() - first);
    if (auto s = scene.shading->shade({blocks.data() + first, count}, scene.lighting, cameras[0].eye); !s)
      return s.error();
  }
  if (!p.colourOnly.empty()) {
    auto c = scene.shading->shadeColours(p.colourOnly, scene.lighting, cameras[0].eye);
    if (!c) return c.error();
    p.colours = std::move(*c);
  }
  if (particles_) { // unlit: the looks' texels, shaded at load, copied into their blocks
    if (Status s = particles_->shade(*scene.looks, atlas_, firstLook, *scene.shading, st.particles); !s) return s;
    st.shadedTexels += st.particles.texels;
  }
  st.shadingMs = msSince(tShade);

  // The atlas read back into this client's memory: the next client's shading overwrites the GPU's.
  auto tRead = Clock::now();
  if (video_) {
    if (Status s = scene.shading->convertAtlasYuv(yuv_); !s) return s.error();
  } else {
    p.atlas = scene.shading->readAtlas();
  }
  st.readbackMs = msSince(tRead);
  st.gpuPasses = scene.shading->takePassTimes();
  for (const gpu::PassTime& t : st.gpuPasses)
    if (t.name.find('.') == std::string::npos) // a stage's parts are inside its own time
      (t.name == "visibility" ? st.gpuVisibilityMs
       : t.name == "yuv"      ? st.gpuConvertMs
                              : st.gpuShadingMs) += t.milliseconds;
  st.totalMs = msSince(t0);
  prepared_ = std::move(p);
  return Ok{};
}

Result<Frame> ClientStream::finishFrame(const StreamScene& scene, StreamFrameStats* stats) {
  if (!prepared_) return Error{"finishFrame: no frame prepared"};
  Prepared p = std::move(*prepared_);
  prepared_.reset();
  StreamFrameStats& st = p.stats;
  auto tEncode = Clock::now();
  Frame frame;
  frame.atlas.codec = config_.codec;
  frame.atlas.width = scene.atlasSize;
  frame.atlas.height = stackedAlpha_ ? 2 * scene.atlasSize : scene.atlasSize;
  if (video_) {
    if (link_) video_->setBitrate(link_->videoKbps());
    auto packet = video_->encodeI420(yuv_.i420(), keyframe_);
    if (!packet) return packet.error();
    frame.atlas.bytes = std::move(packet->data);
  } else {
    std::span<const uint8_t> image = p.atlas.pixels;
    if (stackedAlpha_) { // colour on top, alpha below as grey (docs/stream.md, "Stacked alpha")
      size_t texels = size_t(p.atlas.width) * p.atlas.height;
      stacked_.resize(texels * 8);
      std::copy(p.atlas.pixels.begin(), p.atlas.pixels.end(), stacked_.begin());
      for (size_t i = 0; i < texels; ++i) {
        uint8_t a = p.atlas.pixels[i * 4 + 3];
        uint8_t* out = &stacked_[(texels + i) * 4];
        out[0] = out[1] = out[2] = a;
        out[3] = 255;
      }
      image = stacked_;
    }
    auto bytes = tiles_ ? tiles_->encode(image) : jpeg_->encode(image);
    if (!bytes) return bytes.error();
    frame.atlas.bytes = std::move(*bytes);
  }
  keyframe_ = false;
  st.encodeMs = msSince(tEncode);
  st.atlasBytes = frame.atlas.bytes.size();

  auto tPatches = Clock::now();
  diffPatches(scene, p.placed, p.colourOnly, p.keptColourOnly, p.colours, frame, st);
  if (particles_) particles_->diff(*scene.looks, atlas_, scene.patches.patchCount(), frame);
  frame.particleCodec = PatchCodec::Raw;
  st.particleRawBytes = st.particleBytes = particleSectionBytes(frame);
  if (config_.zstdPatches && !frame.particles.empty()) {
    frame.particleCodec = PatchCodec::Zstd;
    st.particleBytes = particleSectionBytes(frame);
    if (st.particleBytes >= st.particleRawBytes) {
      frame.particleCodec = PatchCodec::Raw;
      st.particleBytes = st.particleRawBytes;
    }
  }
  frame.sequence = ++sequence_;
  frame.poseSequence = p.poseSequence;
  frame.serverTimeUs = microsecondsNow();
  st.patchesMs = msSince(tPatches);
  st.totalMs += msSince(tEncode);
  st.videoTargetKbps = video_ ? video_->config().bitrateKbps : 0;
  if (link_) link_->account(st.atlasBytes, st.geometryBytes + st.particleBytes);
  if (stats) *stats = st;
  return frame;
}

void ClientStream::diffPatches(const StreamScene& scene, const std::vector<std::pair<uint32_t, AtlasPlacement>>& placed,
                               const std::vector<uint32_t>& colourOnly, const std::vector<uint32_t>& keptColourOnly,
                               const std::vector<glm::u8vec4>& colours, Frame& frame, StreamFrameStats& st) {
  kept_.beginFrame(sequence_ + 1); // the frame this one will be (produceFrame numbers it last)
  // What the client holds next: the patches with a block, and the visible ones without (colour-only).
  DenseIdMap<Held>& next = next_;
  next.clear();
  next.reserve(placed.size() + colourOnly.size() + keptColourOnly.size());
  for (const auto& [id, block] : placed) next[id] = Held{block, {}};
  for (uint32_t id : colourOnly) next[id] = Held{};
  for (uint32_t id : keptColourOnly) next[id] = Held{};
  for (const auto& [id, held] : held_)
    if (!next.contains(id)) frame.removed.push_back(id);
  std::sort(frame.removed.begin(), frame.removed.end());
  std::vector<uint32_t> nextIds;
  nextIds.reserve(next.size());
  for (const auto& [id, held] : next) nextIds.push_back(id);
  std::sort(nextIds.begin(), nextIds.end());
  for (uint32_t id : nextIds) {
    Held& now = *next.find(id);
    const Held* before = held_.find(id);
    if (before && before->block == now.block) {
      now.colour = before->colour; // unchanged: the client keeps its colour
      continue;
    }
    PatchUpdate u;
    u.id = id;
    const Patch& patch = scene.patches.patch(scene.patches.patchRef(id));
    u.triangleCount = uint8_t(patch.triangleCount);
    // The client has the geometry when it holds the patch, or was told to remove it lately.
    u.geometry = !before && !kept_.take(id);
    if (u.geometry) {
      u.alpha = patchAlphaMode(scene, id);
      glm::vec3 world[MIRAGE_ATLAS_MAX_PATCH_VERTICES];
      patchWorldPositions(scene.scene, scene.patches, id, world);
      for (uint32_t v = 0; v < patchVertexCount(patch.triangleCount); ++v)
        u.positions[v] = quantizePosition(world[v], scene.bounds.min, scene.positionStep);
    } else {
      st.blockOnly++;
    }
    if (now.block) {
      u.blockX = uint16_t(now.block->x);
      u.blockY = uint16_t(now.block->y);
      u.blockLog2 = uint8_t(now.block->log2);
    } else {
      u.blockLog2 = kColourOnlyBlock; // the entry clears the client's colour: one follows below
    }
    frame.updated.push_back(u);
  }
  // Colours of colour-only patches the client does not have yet (new to it, or changed).
  for (size_t i = 0; i < colourOnly.size(); ++i) {
    std::array<uint8_t, 4> rgba = {colours[i].r, colours[i].g, colours[i].b, colours[i].a};
    Held& h = next[colourOnly[i]];
    if (h.colour == rgba) continue;
    h.colour = rgba;
    frame.colours.push_back({colourOnly[i], rgba});
  }
  for (uint32_t id : frame.removed) {
    kept_.keep(id, Nothing{});
    lastVisible_.erase(id);
  }
  std::swap(held_, next_);

  frame.patchCodec = PatchCodec::Raw;
  st.geometryRawBytes = st.geometryBytes = patchSectionBytes(frame);
  if (config_.zstdPatches) {
    frame.patchCodec = PatchCodec::Zstd;
    st.geometryBytes = patchSectionBytes(frame);
    if (st.geometryBytes >= st.geometryRawBytes) {
      frame.patchCodec = PatchCodec::Raw;
      st.geometryBytes = st.geometryRawBytes;
    }
  }
  st.addedOrMoved = uint32_t(frame.updated.size());
  st.removed = uint32_t(frame.removed.size());
  st.colours = uint32_t(frame.colours.size());
}

} // namespace mirage::stream
