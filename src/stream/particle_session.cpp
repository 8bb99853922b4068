// One client's particles on the server (particle_session.h; docs/stream.md, "Particles").
#include "mirage/stream/particle_session.h"

#include <algorithm>

namespace mirage::stream {

namespace {

uint64_t particleKey(uint32_t system, uint32_t spawn) { return uint64_t(system) << 32 | spawn; }

} // namespace

ClientParticles::ClientParticles(const particles::EffectFile& effect, ParticlePatches mode)
    : mode_(mode), sim_(particles::makeSimulation(effect, kStreamParticleStep)) {}

void ClientParticles::prepare(const ParticleLooks& looks, uint32_t frame, std::span<const ParticleView> views) {
  while (steps_ < frame) {
    particles::step(sim_);
    ++steps_;
  }
  records_.resize(particles::liveParticles(sim_));
  particles::writeRenderParticles(sim_, records_);
  systemOf_.clear();
  for (uint32_t s = 0; s < sim_.pools.size(); ++s) systemOf_.insert(systemOf_.end(), sim_.pools[s].live, s);
  visible_ = visibleParticles(records_, views);
  visibleLook_.resize(visible_.size());
  used_.clear();
  auto textureOf = [&](const VisibleParticle& v) { return looks.look(systemOf_[v.record], records_[v.record].frame); };

  if (mode_ == ParticlePatches::Merged) {
    // Texture merging: one block per look, sized for its largest particle (its master).
    std::vector<float> largest(looks.lookCount(), -1.0f);
    for (size_t k = 0; k < visible_.size(); ++k) {
      uint32_t look = textureOf(visible_[k]);
      visibleLook_[k] = look;
      largest[look] = std::max(largest[look], visible_[k].pixels);
    }
    for (uint32_t look = 0; look < looks.lookCount(); ++look)
      if (largest[look] >= 0.0f) used_.push_back({look, look, largest[look]});
    return;
  }

  // One block per particle: a slot per particle while it stays visible. Slots of particles gone
  // from view are freed first (smallest reused first), so the slot ids stay below the largest
  // number of particles visible at once.
  std::unordered_map<uint64_t, uint32_t> kept;
  for (const VisibleParticle& v : visible_) {
    uint64_t key = particleKey(systemOf_[v.record], records_[v.record].id);
    if (auto it = slotOf_.find(key); it != slotOf_.end()) {
      kept.emplace(key, it->second);
      slotOf_.erase(it);
    }
  }
  for (const auto& [key, slot] : slotOf_) freeSlots_.push_back(slot);
  std::sort(freeSlots_.begin(), freeSlots_.end(), std::greater<>());
  slotOf_ = std::move(kept);
  for (size_t k = 0; k < visible_.size(); ++k) {
    const VisibleParticle& v = visible_[k];
    auto [it, added] = slotOf_.try_emplace(particleKey(systemOf_[v.record], records_[v.record].id), 0u);
    if (added) {
      if (freeSlots_.empty()) {
        it->second = slotCount_++;
      } else {
        it->second = freeSlots_.back();
        freeSlots_.pop_back();
      }
    }
    visibleLook_[k] = it->second;
    used_.push_back({it->second, textureOf(v), v.pixels});
  }
  std::sort(used_.begin(), used_.end(), [](const Used& a, const Used& b) { return a.id < b.id; });
}

void ClientParticles::appendRequests(uint32_t firstId, float bias, std::vector<AtlasRequest>& requests) const {
  for (const Used& u : used_) requests.push_back({firstId + u.id, 3, particleBlockLog2(u.pixels, bias)});
}

void ClientParticles::appendExtents(float bias, std::vector<PatchExtent>& extents) const {
  // A block stops at kParticleMaxBlockLog2: fitting counts it at most that large, and wide (its
  // level 0 and the mip chain beside it).
  for (const Used& u : used_) extents.push_back({std::min(u.pixels, particleCapLength(bias)), 3});
}

Status ClientParticles::shade(const ParticleLooks& looks, const AtlasAllocator& allocator, uint32_t firstId,
                              render::AtlasShading& shading, ParticleFrameStats& stats) const {
  stats.visible = uint32_t(visible_.size());
  stats.looks = uint32_t(used_.size());
  std::vector<ImageRGBA8> texels;
  std::vector<render::AtlasRegionWrite> writes;
  texels.reserve(used_.size());
  for (const Used& u : used_) {
    std::optional<AtlasPlacement> block = allocator.placement(firstId + u.id);
    if (!block) {
      stats.colourOnly++;
      continue;
    }
    // The block's texels on their own (level 0 and its mips beside it), then copied into place.
    ImageRGBA8& image = texels.emplace_back(ImageRGBA8{
        block->width(), block->height(), std::vector<uint8_t>(size_t(block->width()) * block->height() * 4)});
    stats.texels += looks.write(u.texture, AtlasPlacement{0, 0, block->log2, block->wide}, image);
    writes.push_back({block->x, block->y, &image});
  }
  return shading.writeAtlasRegions(writes);
}

ClientParticles::Held ClientParticles::current(const ParticleLooks& looks, const AtlasAllocator& allocator,
                                               uint32_t firstId, const Used& u) const {
  Held h;
  h.block = allocator.placement(firstId + u.id);
  if (!h.block) h.colour = looks.colour(u.texture);
  return h;
}

void ClientParticles::diff(const ParticleLooks& looks, const AtlasAllocator& allocator, uint32_t firstId,
                           Frame& frame) {
  std::unordered_map<uint32_t, Held> next;
  next.reserve(used_.size());
  for (const Used& u : used_) {
    Held h = current(looks, allocator, firstId, u);
    auto before = held_.find(u.id);
    if (before == held_.end() || !(before->second == h)) {
      ParticleLook l;
      l.id = u.id;
      if (h.block) {
        l.blockX = uint16_t(h.block->x);
        l.blockY = uint16_t(h.block->y);
        l.blockLog2 = uint8_t(h.block->log2);
      } else {
        l.blockLog2 = kColourOnlyBlock;
        l.rgba = h.colour;
      }
      frame.looks.push_back(l);
    }
    next.emplace(u.id, h);
  }
  frame.particles.clear();
  if (!visible_.empty()) {
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(std::numeric_limits<float>::lowest());
    for (const VisibleParticle& v : visible_) {
      lo = glm::min(lo, records_[v.record].position);
      hi = glm::max(hi, records_[v.record].position);
    }
    frame.particleOrigin = lo;
    frame.particleStep = particleGridStep(lo, hi);
    frame.particles.reserve(visible_.size());
    for (size_t k = 0; k < visible_.size(); ++k) {
      const shaderio::RenderParticle& r = records_[visible_[k].record];
      frame.particles.push_back(quantizeParticle(r.position, r.size, r.rotation, r.color, visibleLook_[k],
                                                 frame.particleOrigin, frame.particleStep));
    }
  }
  held_ = std::move(next);
}

} // namespace mirage::stream
