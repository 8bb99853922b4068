// GVS++ sampler (gvs.h): random sampling, adaptive border sampling, reverse sampling.
#include <algorithm>
#include <chrono>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "mirage/visibility/gvs.h"
#include "sampling.h"

namespace mirage::vis {

GvsConfig randomOnlyConfig(uint64_t rays, uint64_t seed) {
  GvsConfig c;
  c.randomRays = std::max<uint64_t>(1, std::min<uint64_t>(rays, 1'000'000));
  c.rayBudget = rays;
  c.adaptiveBorder = false;
  c.reverseSampling = false;
  c.minNewTriangles = 0; // never "stable": run until the budget is spent
  c.maxIterations = ~0u;
  c.seed = seed;
  return c;
}

namespace {

using detail::RandomizedHalton;

// A newly found triangle and the origin of the ray that found it (ABS shoots from there).
struct Discovery {
  uint32_t triangle;
  glm::vec3 origin;
};

// Where an ABS ray met a discontinuity: the point it aimed at and the nearer triangle (or none).
struct RsSeed {
  glm::vec3 target;
  uint32_t occluder;
};

// Möller-Trumbore: does the segment origin → origin + dir (t in (0, 1)) cross the triangle?
bool segmentHitsTriangle(glm::vec3 o, glm::vec3 d, const std::array<glm::vec3, 3>& tri) {
  glm::vec3 e1 = tri[1] - tri[0], e2 = tri[2] - tri[0];
  glm::vec3 p = glm::cross(d, e2);
  float det = glm::dot(e1, p);
  if (std::abs(det) < 1e-20f) return false;
  float inv = 1.0f / det;
  glm::vec3 s = o - tri[0];
  float u = glm::dot(s, p) * inv;
  if (u < 0.0f || u > 1.0f) return false;
  glm::vec3 q = glm::cross(s, e1);
  float v = glm::dot(d, q) * inv;
  if (v < 0.0f || u + v > 1.0f) return false;
  float t = glm::dot(e2, q) * inv;
  return t > 1e-4f && t < 1.0f - 1e-4f;
}

class Baker {
public:
  Baker(RayBackend& backend, const Scene& scene, const ViewCell& cell, const GvsConfig& config,
        const BakeOptions& options)
      : backend_(backend), scene_(scene), cfg_(config), offsets_(triangleOffsets(scene)),
        found_(backend.triangleCount()), surface_(cell), halton_(config.seed), rsHalton_(config.seed ^ 0x9e3779b9u),
        keepWitnesses_(options.keepWitnesses), checkpointRays_(options.checkpointRays),
        batch_(backend.preferredBatchRays()) {
    // Meshes without bounds (hand-made scenes) leave the world bounds empty: drop the scene term.
    Bounds b = scene.worldBounds();
    sceneDiagonal_ = b.empty() ? 0.0f : glm::length(b.extent());
    if (!std::isfinite(sceneDiagonal_)) sceneDiagonal_ = 0.0f;
    for (const auto& e : cell.edges()) {
      edges_.push_back(e);
      edgeLength_ += glm::length(e[1] - e[0]);
    }
  }

  CellPvs run() {
    auto t0 = std::chrono::steady_clock::now();
    uint32_t stable = 0;
    for (uint32_t iter = 0; iter < cfg_.maxIterations && budgetLeft(); ++iter) {
      size_t before = found_.count();
      halton_.reshuffle();
      auto tr = std::chrono::steady_clock::now();
      phaseTrace_ = &result_.stats.randomTraceSeconds;
      std::vector<Discovery> queue = randomPhase();
      result_.stats.randomSeconds += secondsSince(tr);
      while (!queue.empty() && cfg_.adaptiveBorder && budgetLeft()) {
        std::vector<Discovery> next;
        auto ta = std::chrono::steady_clock::now();
        const double rsBefore = result_.stats.rsSeconds;
        absPhase(queue, next);
        result_.stats.absSeconds += secondsSince(ta) - (result_.stats.rsSeconds - rsBefore);
        queue = std::move(next);
      }
      ++result_.stats.iterations;
      stable = found_.count() - before < cfg_.minNewTriangles ? stable + 1 : 0;
      if (stable >= cfg_.stableIterations) break;
    }
    result_.triangles = found_.sorted();
    result_.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return std::move(result_);
  }

private:
  static double secondsSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  void checkpoint() {
    // One snapshot however many requested counts this batch passed: rays strictly increase.
    bool reached = false;
    while (nextCheckpoint_ < checkpointRays_.size() && result_.stats.rays >= checkpointRays_[nextCheckpoint_]) {
      reached = true;
      ++nextCheckpoint_;
    }
    if (reached) result_.checkpoints.push_back({result_.stats.rays, found_.sorted()});
  }

  bool budgetLeft() const { return cfg_.rayBudget == 0 || result_.stats.rays < cfg_.rayBudget; }
  uint64_t budgetClamp(uint64_t n) const {
    return cfg_.rayBudget == 0 ? n : std::min<uint64_t>(n, cfg_.rayBudget - result_.stats.rays);
  }

  // Trace rays_[0, n) into hits_, recording into found_; append each new discovery to `out`.
  void traceAndCollect(size_t n, std::vector<Discovery>& out) {
    // Which of several rays hitting a new triangle wins the atomic insert depends on thread
    // timing. Against a snapshot of the set taken before the batch, the lowest-indexed ray that
    // hit a triangle absent from it is credited instead, so discoveries (and with them the ABS
    // origins and every later ray) are the same on any number of threads.
    found_.snapshot(before_);
    auto t0 = std::chrono::steady_clock::now();
    backend_.trace(std::span(rays_.data(), n), std::span(hits_.data(), n), {.record = &found_});
    const double traced = secondsSince(t0);
    result_.stats.traceSeconds += traced;
    *phaseTrace_ += traced;
    result_.stats.rays += n;
    auto claim = [&](uint32_t t, size_t i) {
      if (t == kNoHit || (before_[t >> 6] >> (t & 63) & 1)) return;
      before_[t >> 6] |= uint64_t(1) << (t & 63); // later rays of the batch find it taken
      out.push_back({t, rays_[i].origin});
      if (keepWitnesses_) result_.witnesses.push_back({t, rays_[i]});
    };
    for (size_t i = 0; i < n; ++i) {
      claim(hits_[i].triangle, i);
      // Glass and cut-outs are discoveries too: ABS around them finds their frames, and its rays
      // pass through them to what lies behind.
      claim(hits_[i].seeThrough, i);
    }
    checkpoint();
  }

  // Random rays made by the backend where they are traced: only first discoveries come back, and
  // the host rebuilds the discovering ray from its Halton index (the same map, in float on both
  // sides: the origin agrees to rounding, which ABS does not notice).
  bool generatedRandomBatch(uint64_t base, size_t n, std::vector<Discovery>& out) {
    CellRaySource source{surface_.faces, surface_.cdf, halton_.offsets(), base};
    firstHits_.clear();
    auto t0 = std::chrono::steady_clock::now();
    if (!backend_.traceCellRays(source, n, found_, firstHits_)) return false;
    const double traced = secondsSince(t0);
    result_.stats.traceSeconds += traced;
    *phaseTrace_ += traced;
    result_.stats.rays += n;
    result_.stats.generatedRandomRays = true;
    // Atomics append in scheduling order: sort to the order the host path credits them in.
    std::sort(firstHits_.begin(), firstHits_.end(), [](const FirstHit& a, const FirstHit& b) {
      return a.ray != b.ray ? a.ray < b.ray : a.triangle < b.triangle;
    });
    for (const FirstHit& f : firstHits_) {
      auto h = halton_(base + f.ray);
      Ray ray{};
      ray.origin = surface_.point(h[0], h[1], h[2]);
      ray.dir = detail::sphereDirection(h[3], h[4]);
      out.push_back({f.triangle, ray.origin});
      if (keepWitnesses_) result_.witnesses.push_back({f.triangle, ray});
    }
    checkpoint();
    return true;
  }

  std::vector<Discovery> randomPhase() {
    std::vector<Discovery> out;
    uint64_t total = budgetClamp(cfg_.randomRays);
    for (uint64_t done = 0; done < total;) {
      // Generated rays cost no per-ray traffic, so their batches are larger (fewer submissions,
      // fewer read-backs of the discoveries); they still end at checkpoints for the budget.
      if (generate_) {
        size_t n = size_t(std::min<uint64_t>(std::min<uint64_t>(batch_ * 8, uint64_t(1) << 31), total - done));
        if (generatedRandomBatch(haltonIndex_, n, out)) {
          haltonIndex_ += n;
          result_.stats.randomRays += n;
          done += n;
          continue;
        }
        generate_ = false; // the backend cannot: make the rays here from now on
      }
      size_t n = size_t(std::min<uint64_t>(batch_, total - done));
      rays_.resize(n);
      hits_.resize(n);
      uint64_t base = haltonIndex_;
      tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t>& r) {
        auto cursor = halton_.cursor(base + r.begin());
        for (size_t i = r.begin(); i < r.end(); ++i, cursor.next()) {
          auto h = cursor();
          Ray& ray = rays_[i];
          ray = Ray{};
          ray.origin = surface_.point(h[0], h[1], h[2]);
          ray.dir = detail::sphereDirection(h[3], h[4]);
        }
      });
      haltonIndex_ += n;
      traceAndCollect(n, out);
      result_.stats.randomRays += n;
      done += n;
    }
    return out;
  }

  // The 9-vertex border polygon of `tri` enlarged by delta, sampled: its 9 vertices plus
  // `edgeSamples` points inside each of its 3 long edges (the ones parallel to the triangle's).
  static void borderPoints(const std::array<glm::vec3, 3>& tri, float delta, uint32_t edgeSamples,
                           std::vector<glm::vec3>& out) {
    glm::vec3 n = glm::cross(tri[1] - tri[0], tri[2] - tri[0]);
    if (glm::dot(n, n) < 1e-30f) return; // degenerate: no border to follow
    glm::vec3 en[3];                     // outward in-plane normal of edge i → i+1
    for (int i = 0; i < 3; ++i) {
      glm::vec3 p = tri[size_t(i)], q = tri[size_t((i + 1) % 3)], r = tri[size_t((i + 2) % 3)];
      glm::vec3 e = glm::normalize(glm::cross(q - p, n));
      en[i] = glm::dot(e, r - p) > 0.0f ? -e : e;
    }
    for (int i = 0; i < 3; ++i) {
      glm::vec3 v = tri[size_t(i)];
      glm::vec3 prev = en[(i + 2) % 3], next = en[i];
      out.push_back(v + delta * prev);
      out.push_back(v + delta * glm::normalize(prev + next));
      glm::vec3 a = v + delta * next, b = tri[size_t((i + 1) % 3)] + delta * next;
      out.push_back(a);
      for (uint32_t s = 0; s < edgeSamples; ++s) out.push_back(glm::mix(a, b, float(s + 1) / float(edgeSamples + 1)));
    }
  }

  // Rays are generated in parallel into fixed slots (one block per discovery or seed); unused
  // slots get tfar < 0 and are squeezed out before tracing, so every traced ray is a real sample.
  void compact(std::vector<glm::vec3>* targets) {
    size_t out = 0;
    for (size_t i = 0; i < rays_.size(); ++i) {
      if (rays_[i].tfar < 0.0f) continue;
      rays_[out] = rays_[i];
      if (targets) (*targets)[out] = (*targets)[i];
      ++out;
    }
    rays_.resize(out);
    if (targets) targets->resize(out);
  }

  // ABS in chunks of about one batch of rays; each chunk's discontinuities are reverse-sampled
  // right away, so the seed list stays batch-sized however many triangles an iteration finds.
  void absPhase(const std::vector<Discovery>& queue, std::vector<Discovery>& next) {
    std::vector<RsSeed> seeds;
    const size_t perTriangle = 9 + 3 * size_t(cfg_.absEdgeSamples);
    const size_t chunk = std::max<size_t>(1, batch_ / perTriangle);
    std::vector<glm::vec3> targets;
    phaseTrace_ = &result_.stats.absTraceSeconds;
    for (size_t begin = 0; begin < queue.size() && budgetLeft(); begin += chunk) {
      size_t end = std::min(queue.size(), begin + chunk);
      rays_.assign((end - begin) * perTriangle, Ray{.tfar = -1.0f});
      targets.resize(rays_.size());
      tbb::parallel_for(tbb::blocked_range<size_t>(begin, end, 64), [&](const tbb::blocked_range<size_t>& r) {
        std::vector<glm::vec3> pts;
        for (size_t q = r.begin(); q < r.end(); ++q) {
          auto tri = worldTriangle(scene_, offsets_, queue[q].triangle);
          float longest =
              std::max({glm::length(tri[1] - tri[0]), glm::length(tri[2] - tri[1]), glm::length(tri[0] - tri[2])});
          float delta = cfg_.absDeltaTriangle * longest + cfg_.absDeltaScene * sceneDiagonal_;
          pts.clear();
          borderPoints(tri, delta, cfg_.absEdgeSamples, pts);
          size_t slot = (q - begin) * perTriangle;
          for (glm::vec3 p : pts) {
            glm::vec3 d = p - queue[q].origin;
            if (glm::dot(d, d) < 1e-30f) continue;
            rays_[slot] = Ray{.origin = queue[q].origin, .dir = glm::normalize(d)};
            targets[slot++] = p;
          }
        }
      });
      compact(&targets);
      size_t n = size_t(budgetClamp(rays_.size()));
      hits_.resize(rays_.size());
      traceAndCollect(n, next);
      result_.stats.absRays += n;
      seeds.clear();
      for (size_t i = 0; i < n; ++i) {
        float dist = glm::length(targets[i] - rays_[i].origin);
        if (hits_[i].triangle == kNoHit || hits_[i].t < dist * (1.0f - cfg_.rsDeltaRelative))
          seeds.push_back({targets[i], hits_[i].triangle});
      }
      result_.stats.discontinuities += seeds.size();
      if (cfg_.reverseSampling) {
        auto tr = std::chrono::steady_clock::now();
        phaseTrace_ = &result_.stats.rsTraceSeconds;
        rsPhase(seeds, next);
        phaseTrace_ = &result_.stats.absTraceSeconds;
        result_.stats.rsSeconds += secondsSince(tr);
      } // reuses rays_/hits_: the seeds hold what RS needs
    }
  }

  glm::vec3 edgePoint(float s) const {
    float at = s * edgeLength_;
    for (const auto& e : edges_) {
      float len = glm::length(e[1] - e[0]);
      if (at <= len) return glm::mix(e[0], e[1], len > 0.0f ? at / len : 0.0f);
      at -= len;
    }
    return edges_.back()[1];
  }

  void rsPhase(const std::vector<RsSeed>& seeds, std::vector<Discovery>& next) {
    const size_t perSeed = size_t(cfg_.rsEdgeSamples) + cfg_.rsAreaSamples;
    if (perSeed == 0) return;
    const size_t chunk = std::max<size_t>(1, batch_ / perSeed);
    for (size_t begin = 0; begin < seeds.size() && budgetLeft(); begin += chunk) {
      size_t end = std::min(seeds.size(), begin + chunk);
      rays_.assign((end - begin) * perSeed, Ray{.tfar = -1.0f});
      const uint64_t base = rsIndex_;
      tbb::parallel_for(tbb::blocked_range<size_t>(begin, end, 64), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t s = r.begin(); s < r.end(); ++s) {
          const RsSeed& seed = seeds[s];
          const uint64_t index = base + (s - begin);
          std::array<glm::vec3, 3> occ{};
          if (seed.occluder != kNoHit) occ = worldTriangle(scene_, offsets_, seed.occluder);
          size_t slot = (s - begin) * perSeed;
          auto emit = [&](glm::vec3 o) {
            glm::vec3 d = seed.target - o;
            if (glm::dot(d, d) < 1e-30f) return;
            // Inside the occluder's shadow on the cell: the occluder blocks this origin too.
            if (seed.occluder != kNoHit && segmentHitsTriangle(seed.target, o - seed.target, occ)) return;
            rays_[slot++] = Ray{.origin = o, .dir = glm::normalize(d)};
          };
          // Edge origins evenly spread along the cell's edges, shifted per seed so seeds differ.
          float shift = detail::radicalInverse(index, 2);
          for (uint32_t j = 0; j < cfg_.rsEdgeSamples; ++j)
            emit(edgePoint((float(j) + shift) / float(cfg_.rsEdgeSamples)));
          for (uint32_t j = 0; j < cfg_.rsAreaSamples; ++j) {
            auto h = rsHalton_(index * cfg_.rsAreaSamples + j);
            emit(surface_.point(h[0], h[1], h[2]));
          }
        }
      });
      rsIndex_ += end - begin;
      compact(nullptr);
      size_t n = size_t(budgetClamp(rays_.size()));
      hits_.resize(rays_.size());
      traceAndCollect(n, next);
      result_.stats.rsRays += n;
    }
  }

  RayBackend& backend_;
  const Scene& scene_;
  const GvsConfig& cfg_;
  std::vector<uint64_t> offsets_;
  TriangleSet found_;
  detail::SurfaceSampler surface_;
  RandomizedHalton<5> halton_; // face, u, v, direction u, direction v
  RandomizedHalton<3> rsHalton_;
  uint64_t haltonIndex_ = 0;
  uint64_t rsIndex_ = 0;
  bool keepWitnesses_;
  std::vector<uint64_t> checkpointRays_;
  size_t nextCheckpoint_ = 0;
  bool generate_ = true; // try the backend's own random rays (traceCellRays) first
  std::vector<FirstHit> firstHits_;
  double* phaseTrace_ = nullptr; // the current phase's share of the trace time
  const size_t batch_;           // rays per trace call (the backend's choice: 256 k fill all CPU cores)
  float sceneDiagonal_ = 1.0f;
  std::vector<std::array<glm::vec3, 2>> edges_;
  float edgeLength_ = 0.0f;
  std::vector<Ray> rays_;
  std::vector<Hit> hits_;
  std::vector<uint64_t> before_; // found_ before the current batch, plus the batch's claims
  CellPvs result_;
};

} // namespace

CellPvs computeCellPvs(RayBackend& backend, const Scene& scene, const ViewCell& cell, const GvsConfig& config,
                       bool keepWitnesses) {
  return computeCellPvs(backend, scene, cell, config, BakeOptions{.keepWitnesses = keepWitnesses});
}

CellPvs computeCellPvs(RayBackend& backend, const Scene& scene, const ViewCell& cell, const GvsConfig& config,
                       const BakeOptions& options) {
  return Baker(backend, scene, cell, config, options).run();
}

CellPvs bruteForcePvs(RayBackend& backend, const Scene& scene, const ViewCell& cell, uint64_t raysPerRound,
                      uint32_t stableRounds, uint64_t seed) {
  GvsConfig c;
  c.randomRays = raysPerRound;
  c.adaptiveBorder = false;
  c.reverseSampling = false;
  c.minNewTriangles = 1; // a round is "stable" when it found nothing new
  c.stableIterations = stableRounds;
  c.maxIterations = ~0u;
  c.seed = seed;
  return computeCellPvs(backend, scene, cell, c);
}

} // namespace mirage::vis
