#pragma once
// GVS++ (Koch & Wimmer 2021, after Wonka et al. 2006 "Guided Visibility Sampling"): an aggressive
// from-region PVS. Every triangle in the result was hit by a traced ray from the cell (never
// conservative junk); what it misses shows up as pixel error (pvs_eval.h).
// The work: random rays (one randomized Halton sequence of origins on the cell surface and uniform
// sphere directions), adaptive border sampling (ABS) around every newly found triangle, and
// reverse sampling (RS) wherever an ABS ray met a discontinuity. The schedule is anytime: each
// step traces about one batch, of random rays or of the queued ABS/RS work worth most, whichever
// is expected to find more per ray, so a bake cut short by `rayBudget` is never worse than
// random rays alone (docs/visibility.md, "Anytime schedule"). The bake stops when fewer than T
// new triangles were found in each of k consecutive iterations of n_rand random rays, and the
// queued work is done.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "mirage/core/result.h"

#include "mirage/core/scene.h"
#include "mirage/visibility/ray_backend.h"
#include "mirage/visibility/view_cell.h"

namespace mirage::vis {

struct GvsConfig {
  // n_rand: random rays per iteration. The seed's 10 M suits a GPU; on a 2-core CPU 10^5..10^6
  // finds the same sets on small scenes, since ABS does most of the discovering.
  uint64_t randomRays = 10'000'000;
  // n_ABSEdge: samples on each of the 3 long edges of the enlarged 9-vertex border polygon, plus
  // its 9 vertices (40 → 129 rays per new triangle, as in the seed).
  uint32_t absEdgeSamples = 40;
  // Δ_ABS, the border enlargement, relative (never in world units, so results do not depend on the
  // scene's units): this fraction of the triangle's longest edge ...
  float absDeltaTriangle = 1e-3f;
  // ... plus this fraction of the scene's bounding-box diagonal (keeps tiny triangles' borders from
  // collapsing onto their own edges).
  float absDeltaScene = 1e-5f;
  // A discontinuity: the ABS ray hit nearer than its target by more than this fraction of the
  // target's distance (the seed: 0.985 world units), or it missed everything.
  float rsDeltaRelative = 0.02f;
  // n_RSEdge / n_RSArea: reverse-sampling origins per discontinuity along the cell's edges and as
  // Halton points on its surface; origins inside the occluder's shadow (projection from the target
  // onto the cell) are skipped.
  uint32_t rsEdgeSamples = 20;
  uint32_t rsAreaSamples = 20;
  // Termination: fewer than T new triangles in k consecutive iterations.
  uint32_t minNewTriangles = 10; // T
  uint32_t stableIterations = 3; // k
  uint32_t maxIterations = 1000;
  // Stop once this many rays were traced (0: no limit); every step is cut to it, so a bake traces
  // exactly this many unless it converged first. The schedule does not depend on it: a bake with
  // budget B traces the first B rays of the unlimited bake.
  uint64_t rayBudget = 0;
  // Turning both off gives the RAND baseline (random rays only).
  bool adaptiveBorder = true;
  bool reverseSampling = true;
  uint64_t seed = 1;
};

// A GvsConfig from JSON (`mirage pvs --config`): an object whose keys are the snake_case field
// names (random_rays, abs_edge_samples, abs_delta_triangle, abs_delta_scene, rs_delta_relative,
// rs_edge_samples, rs_area_samples, min_new_triangles, stable_iterations, max_iterations,
// ray_budget, adaptive_border, reverse_sampling, seed); missing keys keep `base`. Unknown keys,
// wrong types and out-of-range values are errors "<file>: <problem>".
Result<GvsConfig> parseGvsConfig(const std::string& jsonText, const std::string& fileForErrors,
                                 const GvsConfig& base = {});
std::string gvsConfigToJson(const GvsConfig& config);

// The RAND baseline with exactly `rays` random rays (no termination test): for the same seed the
// very random rays GVS++ traces, without the rest.
GvsConfig randomOnlyConfig(uint64_t rays, uint64_t seed = 1);

struct PvsStats {
  uint64_t rays = 0; // all rays traced
  uint64_t randomRays = 0;
  uint64_t absRays = 0;
  uint64_t rsRays = 0;
  uint64_t discontinuities = 0;
  uint32_t iterations = 0;
  double seconds = 0.0;      // whole bake of the cell
  double traceSeconds = 0.0; // inside RayBackend::trace (the rest generates rays and bookkeeps)
  // Per phase: all of it, and inside the backend (trace or traceCellRays).
  double randomSeconds = 0.0, randomTraceSeconds = 0.0;
  double absSeconds = 0.0, absTraceSeconds = 0.0; // ABS ray making, tracing, discontinuity tests
  double rsSeconds = 0.0, rsTraceSeconds = 0.0;
  bool generatedRandomRays = false;  // the backend made the random rays (traceCellRays)
  bool generatedExploreRays = false; // and the ABS and RS rays (traceExploreRays)
};

// The PVS as it stood when the bake had traced `rays` rays (for plots of size and error against
// rays traced).
struct PvsCheckpoint {
  uint64_t rays = 0;
  std::vector<uint32_t> triangles; // sorted global IDs
};

// The ray that first found a triangle (for the "every PVS triangle was hit" invariant).
struct Witness {
  uint32_t triangle = kNoHit;
  Ray ray;
};

struct CellPvs {
  std::vector<uint32_t> triangles; // sorted global IDs
  PvsStats stats;
  std::vector<Witness> witnesses;         // filled when requested: one per opaque discovery
  std::vector<PvsCheckpoint> checkpoints; // one per requested ray count reached, rays increasing
};

// Where a bake stands, reported after every step (about one batch of rays).
struct GvsProgress {
  uint64_t rays = 0;    // traced so far
  uint64_t budget = 0;  // GvsConfig::rayBudget (0: none, the bake runs until it converges)
  size_t triangles = 0; // found so far
  uint32_t iterations = 0;
  uint64_t randomRays = 0, absRays = 0, rsRays = 0;
  double seconds = 0.0; // since the bake began
};

struct BakeOptions {
  bool keepWitnesses = false;
  // Snapshots of the PVS once at least this many rays were traced (increasing), taken between
  // batches; the final set is not included.
  std::vector<uint64_t> checkpointRays;
  // Called on the baking thread after every step; the CLI prints it (progress per cell).
  std::function<void(const GvsProgress&)> progress;
};

// GVS++ for one cell. `scene` must be the scene the backend was built from (ABS needs triangle
// corners). Runs on all cores through the backend.
CellPvs computeCellPvs(RayBackend& backend, const Scene& scene, const ViewCell& cell, const GvsConfig& config,
                       bool keepWitnesses = false);
CellPvs computeCellPvs(RayBackend& backend, const Scene& scene, const ViewCell& cell, const GvsConfig& config,
                       const BakeOptions& options);

// Dense random sampling until `stableRounds` rounds of `raysPerRound` find nothing new: an estimate
// of the exact visible set on small scenes.
CellPvs bruteForcePvs(RayBackend& backend, const Scene& scene, const ViewCell& cell, uint64_t raysPerRound,
                      uint32_t stableRounds = 10, uint64_t seed = 99);

} // namespace mirage::vis
