// Pixel-error evaluation of a PVS (pvs_eval.h).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>

#include <glm/gtc/quaternion.hpp>

#include "mirage/visibility/pvs_eval.h"
#include "sampling.h"

namespace mirage::vis {

std::vector<glm::vec3> evaluationViewpoints(const ViewCell& cell, const EvalConfig& config) {
  std::vector<glm::vec3> out = cell.corners();
  detail::RandomizedHalton<3> h(config.seed);
  for (uint32_t i = 0; i < config.haltonViewpoints; ++i) {
    auto u = h(i);
    glm::vec3 unit(u[0] - 0.5f, cell.shape == CellShape::Rect ? 0.0f : u[1] - 0.5f, u[2] - 0.5f);
    out.push_back(cell.toWorld(unit));
  }
  return out;
}

namespace {

// Relative depth difference below which two hits are the same surface (float noise of Embree's
// watertight intersection is far smaller; real layers such as a picture on a wall are farther).
constexpr float kSameDepth = 1e-5f;

// Counts 4-connected regions of set pixels and the largest one's size.
void regions(std::vector<uint8_t>& wrong, uint32_t size, uint64_t& count, uint64_t& largest) {
  std::vector<uint32_t> stack;
  for (uint32_t start = 0; start < wrong.size(); ++start) {
    if (!wrong[start]) continue;
    ++count;
    uint64_t area = 0;
    stack.push_back(start);
    wrong[start] = 0;
    while (!stack.empty()) {
      uint32_t p = stack.back();
      stack.pop_back();
      ++area;
      uint32_t x = p % size, y = p / size;
      auto visit = [&](uint32_t q) {
        if (wrong[q]) {
          wrong[q] = 0;
          stack.push_back(q);
        }
      };
      if (x > 0) visit(p - 1);
      if (x + 1 < size) visit(p + 1);
      if (y > 0) visit(p - size);
      if (y + 1 < size) visit(p + size);
    }
    largest = std::max(largest, area);
  }
}

} // namespace

PixelError evaluatePvs(RayBackend& backend, const ViewCell& cell, const TriangleSet& pvs, const EvalConfig& config) {
  PixelError err;
  const uint32_t res = config.resolution;
  err.pixelsPerView = uint64_t(res) * res;
  std::vector<Ray> rays(err.pixelsPerView);
  std::vector<Hit> hits(err.pixelsPerView);
  std::vector<uint8_t> wrong(err.pixelsPerView);
  std::vector<uint32_t> retrace;
  std::vector<Ray> retraceRays;
  std::vector<Hit> retraceHits;
  std::mt19937_64 rng(config.seed);
  std::normal_distribution<float> normal;
  double sumWrong = 0.0;
  const std::vector<glm::vec3> eyes = evaluationViewpoints(cell, config);
  for (glm::vec3 eye : eyes) {
    // A uniformly random rotation (normalized Gaussian quaternion) of the cube frame.
    glm::quat q = glm::normalize(glm::quat(normal(rng), normal(rng), normal(rng), normal(rng)));
    glm::mat3 frame = glm::mat3_cast(q);
    for (int face = 0; face < 6; ++face) {
      glm::vec3 forward = frame[face / 2] * (face % 2 ? -1.0f : 1.0f);
      glm::vec3 up = frame[(face / 2 + 1) % 3];
      glm::vec3 right = glm::cross(forward, up);
      for (uint32_t y = 0; y < res; ++y)
        for (uint32_t x = 0; x < res; ++x) {
          // 90° field of view: the image plane at distance 1 spans [-1, 1].
          float sx = (2.0f * (float(x) + 0.5f) / float(res)) - 1.0f;
          float sy = 1.0f - (2.0f * (float(y) + 0.5f) / float(res));
          Ray& r = rays[size_t(y) * res + x];
          r = Ray{};
          r.origin = eye;
          r.dir = forward + sx * right + sy * up;
        }
      backend.trace(rays, hits, {.require = &pvs, .coherent = true});
      // A missing opaque triangle tied in depth with a PVS triangle (coplanar duplicates, shared
      // edges) is a z-fight the PVS-only render shows at the same depth: re-trace those pixels in
      // the scene reduced to the PVS and count them only if the depth changes. A missing
      // see-through triangle always counts (the glass itself is absent).
      retrace.clear();
      for (size_t i = 0; i < hits.size(); ++i) {
        wrong[i] = (hits[i].flags & kHitMissing) ? 1 : 0;
        if (wrong[i] && hits[i].triangle != kNoHit && !pvs.contains(hits[i].triangle)) retrace.push_back(uint32_t(i));
      }
      retraceRays.resize(retrace.size());
      retraceHits.resize(retrace.size());
      for (size_t k = 0; k < retrace.size(); ++k) retraceRays[k] = rays[retrace[k]];
      backend.trace(retraceRays, retraceHits, {.require = &pvs, .onlyRequired = true});
      for (size_t k = 0; k < retrace.size(); ++k) {
        float t = hits[retrace[k]].t, t2 = retraceHits[k].t;
        if (retraceHits[k].triangle != kNoHit && std::abs(t2 - t) <= kSameDepth * t) wrong[retrace[k]] = 0;
      }
      uint64_t count = 0;
      for (uint8_t w : wrong) count += w;
      regions(wrong, res, err.regions, err.largestRegion);
      sumWrong += double(count);
      err.maxWrong = std::max(err.maxWrong, count);
      ++err.views;
      if (config.progress) config.progress(err.views, uint32_t(eyes.size() * 6));
    }
  }
  err.averageWrong = err.views ? sumWrong / err.views : 0.0;
  return err;
}

uint32_t rasterPoints(const RasterConfig& config) {
  if (config.pixelBudget == 0) return std::max(1u, config.points);
  const uint64_t perPoint = 6ull * config.resolution * config.resolution;
  return uint32_t(std::clamp<uint64_t>((config.pixelBudget + perPoint / 2) / perPoint, 1, 1u << 24));
}

CellPvs rasterPvs(RayBackend& backend, const ViewCell& cell, const RasterConfig& config, const BakeOptions& options) {
  auto t0 = std::chrono::steady_clock::now();
  CellPvs out;
  TriangleSet seen(backend.triangleCount());
  const uint32_t res = std::max(1u, config.resolution);
  std::vector<Ray> rays(size_t(res) * res);
  std::vector<Hit> hits(rays.size());
  detail::RandomizedHalton<3> halton(config.seed);
  const uint32_t points = rasterPoints(config);
  size_t nextCheckpoint = 0;
  for (uint32_t i = 0; i < points; ++i) {
    auto u = halton(i);
    glm::vec3 eye = cell.toWorld({u[0] - 0.5f, cell.shape == CellShape::Rect ? 0.0f : u[1] - 0.5f, u[2] - 0.5f});
    for (int face = 0; face < 6; ++face) {
      glm::vec3 forward(0.0f), up(0.0f);
      forward[face / 2] = face % 2 ? -1.0f : 1.0f;
      up[(face / 2 + 1) % 3] = 1.0f;
      glm::vec3 right = glm::cross(forward, up);
      for (uint32_t y = 0; y < res; ++y)
        for (uint32_t x = 0; x < res; ++x) {
          float sx = (2.0f * (float(x) + 0.5f) / float(res)) - 1.0f;
          float sy = 1.0f - (2.0f * (float(y) + 0.5f) / float(res));
          rays[size_t(y) * res + x] = Ray{.origin = eye, .dir = forward + sx * right + sy * up};
        }
      auto tt = std::chrono::steady_clock::now();
      backend.trace(rays, hits, {.record = &seen, .coherent = true});
      out.stats.traceSeconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - tt).count();
      out.stats.rays += rays.size();
      out.stats.randomRays += rays.size();
    }
    ++out.stats.iterations;
    bool reached = false;
    while (nextCheckpoint < options.checkpointRays.size() && out.stats.rays >= options.checkpointRays[nextCheckpoint]) {
      reached = true;
      ++nextCheckpoint;
    }
    if (reached) out.checkpoints.push_back({out.stats.rays, seen.sorted()});
  }
  out.triangles = seen.sorted();
  out.stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

} // namespace mirage::vis
