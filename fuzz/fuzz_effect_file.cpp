// Effect files (`mirage bench particles FX.toml`): any text is accepted or rejected with one line;
// an accepted file flattens and simulates a few steps within its pools' limits.
#include <algorithm>

#include "fuzz_support.h"
#include "mirage/particles/simulation.h"

using namespace mirage;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string text(reinterpret_cast<const char*>(data), size);
  Result<particles::EffectFile> file = particles::parseEffectFile(text, "fx.toml");
  if (!file) {
    fuzz::checkOneLine(file.error());
    return 0;
  }
  // Bound the work: small pools, no prewarm (a long duration would run many steps).
  for (particles::SystemDef& s : file->systems) {
    s.maxParticles = std::min(s.maxParticles, 256u);
    s.prewarm = false;
  }
  particles::Simulation sim = particles::makeSimulation(*file, 1.0f / 60.0f);
  for (int i = 0; i < 4; ++i) particles::step(sim);
  for (const particles::ParticlePool& p : sim.pools)
    fuzz::check(p.live <= p.def.maxParticles && p.instances.size() == p.def.maxParticles, "pool over its size");
  std::vector<shaderio::RenderParticle> out(particles::liveParticles(sim));
  fuzz::check(particles::writeRenderParticles(sim, out) == out.size(), "render records short");
  return 0;
}
