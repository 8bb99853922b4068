// GVS++ sampler (gvs.h): random sampling, adaptive border sampling, reverse sampling.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <iterator>
#include <limits>
#include <numbers>
#include <type_traits>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "explore_rays.h"
#include "mirage/visibility/gvs.h"
#include "run_queue.h"
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

// Queued exploration work, highest expected gain first (ties: first queued first, so bakes are
// reproducible). `value` is the gain this item is expected to bring, in the units of discoveryValue.
template <class T> struct Queued {
  float value;
  uint64_t order;
  T item;
};
template <class T> struct LowerValue {
  bool operator()(const Queued<T>& a, const Queued<T>& b) const {
    return a.value != b.value ? a.value < b.value : a.order > b.order;
  }
};

// One exploration phase's work list and its record of how well queued value turned into gain.
template <class T> struct Explorer {
  detail::RunQueue<Queued<T>, LowerValue<T>> queue;
  std::vector<Queued<T>> staged; // the next chunk, taken off the queue to price it
  double stagedValue = 0.0;      // its queued value
  size_t raysPerItem = 1;
  size_t chunkRays = 1; // rays of the next chunk: small while the phase's rate is still being learnt
  // Gain found per unit of queued value (running mean of the last chunks); unknown until the
  // phase ran once, and then the phase is tried first (optimism: its rate can only be learnt).
  double gainPerValue = 0.0;
  bool tried = false;
  std::vector<Queued<T>> extra_, merged_; // stage(): what comes off the queue, the chunk merged with it

  bool pending() const { return !queue.empty() || !staged.empty(); }
  size_t size() const { return queue.size() + staged.size(); }
  // Takes the `items` most valuable items as the next chunk (returning the previous one first, as
  // more valuable work may have been queued since) and returns the gain per ray expected of it;
  // negative when nothing is pending.
  double stage(size_t items) {
    // The chunk staged before is still the top `items` when it has that many (or all there are)
    // and nothing queued since ranks above its last item: kept as it is (the common case while
    // the other phases run), so steps cost no re-staging.
    const bool unchanged = !staged.empty() && (staged.size() == items || (staged.size() < items && queue.empty())) &&
                           (queue.empty() || LowerValue<T>()(queue.top(), staged.back()));
    if (!unchanged) {
      // The top `items` of the staged chunk and the queue together, as handing the chunk back and
      // popping `items` would give them: only what ranks among them comes off the queue (most
      // often the few queued since), merged into the chunk, whose cut-off tail goes back as a run.
      LowerValue<T> lower;
      const auto better = [&](const Queued<T>& a, const Queued<T>& b) { return lower(b, a); };
      extra_.clear();
      // How many staged items rank above the queue's top: never fewer as the top gets worse, so
      // each search gallops on from the last answer (a chunk of new seeds that outranks a staged
      // chunk of 50 k costs a few comparisons an item, not a binary search of the chunk).
      size_t above = 0;
      const auto isAbove = [&](size_t i, const Queued<T>& top) { return better(staged[i], top); };
      while (!queue.empty()) {
        const Queued<T>& top = queue.top();
        size_t step = 1;
        while (above + step <= staged.size() && isAbove(above + step - 1, top)) {
          above += step;
          step *= 2;
        }
        const auto end = staged.begin() + ptrdiff_t(std::min(staged.size(), above + step - 1));
        above = size_t(std::partition_point(staged.begin() + ptrdiff_t(above), end,
                                            [&](const Queued<T>& s) { return better(s, top); }) -
                       staged.begin());
        if (above + extra_.size() >= items) break;
        extra_.push_back(top);
        queue.pop();
      }
      if (!extra_.empty()) {
        merged_.clear();
        merged_.reserve(staged.size() + extra_.size());
        std::merge(staged.begin(), staged.end(), extra_.begin(), extra_.end(), std::back_inserter(merged_), better);
        std::swap(staged, merged_);
      }
      if (staged.size() > items) {
        queue.pushRun(std::vector<Queued<T>>(staged.begin() + ptrdiff_t(items), staged.end()));
        staged.resize(items);
      }
      stagedValue = 0.0;
      for (const auto& q : staged) stagedValue += q.value;
    }
    if (staged.empty()) return -1.0;
    if (!tried) return std::numeric_limits<double>::infinity();
    return gainPerValue * stagedValue / double(staged.size() * raysPerItem);
  }
  void record(double value, double gain, size_t stepRays) {
    chunkRays = std::min(stepRays, chunkRays * 2);
    double rate = value > 0.0 ? gain / value : 0.0;
    gainPerValue = tried ? 0.5 * (gainPerValue + rate) : rate;
    tried = true;
  }
};

// Random rays alone for the first two steps: at first nearly every random ray finds something
// large, and the first chunks of ABS and RS, which are needed to learn their rates, would cost rays
// that random sampling uses better. On the scenes of tests/visibility/anytime_test.cpp, checked
// every 5 k rays (every 100 k on the wide cells): exploring from the third step is never worse
// than RAND; from the second, never worse either and better early, but worse at the end (city 1
// at 320 k rays: 0.73 wrong pixels against 0.52); from the fifth, city 1 fell 2 % behind RAND
// around 70 k rays.
constexpr uint64_t kWarmupSteps = 2;
// A phase's first chunk is this fraction of a step, and each later one twice the previous, up to
// a step: a phase that turns out to find little has cost little.
constexpr size_t kFirstChunkDivisor = 16;

// Outstanding RS seeds are capped: beyond this many, reverse sampling runs whatever its yield, so
// memory stays bounded on scenes where ABS finds millions of discontinuities.
constexpr size_t kMaxPendingSeeds = size_t(1) << 21;

class Baker {
public:
  Baker(RayBackend& backend, const Scene& scene, const ViewCell& cell, const GvsConfig& config,
        const BakeOptions& options)
      : backend_(backend), scene_(scene), cfg_(config), options_(options), offsets_(triangleOffsets(scene)),
        found_(backend.triangleCount()), surface_(cell), halton_(config.seed), rsHalton_(config.seed ^ 0x9e3779b9u),
        randomPerIteration_(std::max<uint64_t>(1, config.randomRays)),
        step_(size_t(std::max<uint64_t>(1, std::min<uint64_t>(backend.preferredBatchRays(), randomPerIteration_)))) {
    // Meshes without bounds (hand-made scenes) leave the world bounds empty: drop the scene term.
    Bounds b = scene.worldBounds();
    sceneDiagonal_ = b.empty() ? 0.0f : glm::length(b.extent());
    if (!std::isfinite(sceneDiagonal_)) sceneDiagonal_ = 0.0f;
    for (const auto& e : cell.edges()) edges_.push_back(e);
    probes_ = cell.corners();
    probes_.push_back(cell.position);
    // A cell whose surface points are not traceable rays' origins gives an empty PVS: no ray from
    // it reaches a backend (callers reject such cells first, validateCellsForScene).
    traceable_ = cell.surfaceArea() > 0.0f;
    for (glm::vec3 c : cell.corners()) traceable_ = traceable_ && validRay(Ray{.origin = c});
    border_.raysPerItem = 9 + 3 * size_t(cfg_.absEdgeSamples);
    reverse_.raysPerItem = std::max<size_t>(1, size_t(cfg_.rsEdgeSamples) + cfg_.rsAreaSamples);
    border_.chunkRays = reverse_.chunkRays = std::max<size_t>(1, step_ / kFirstChunkDivisor);
    queue_ = backend.maxQueued() >= 2;
    overlap_ = cfg_.rayBudget == 0 && options_.checkpointRays.empty();
  }

  CellPvs run() {
    auto t0 = std::chrono::steady_clock::now();
    if (traceable_) schedule();
    flush();
    result_.triangles = found_.sorted();
    result_.stats.seconds = secondsSince(t0);
    return std::move(result_);
  }

private:
  enum class Step { Random, Border, Reverse };

  static double secondsSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }

  // The anytime schedule (docs/visibility.md). Every step traces about one batch: a batch of
  // random rays, or a chunk of the most valuable queued ABS or RS work, whichever is expected to
  // gain more per ray. So a bake stopped by the budget at any point has spent its rays where they
  // found the most, and never spends them on the neighbourhood of its first hits while random
  // rays would still find more. Iterations are counted in random rays (randomRays each) and the
  // termination test is the seed's: fewer than T new triangles in k consecutive iterations, then
  // whatever is still queued is explored before the bake stops.
  void schedule() {
    uint64_t iterationEnd = 0; // random rays traced when the current iteration's are spent
    size_t iterationStart = 0; // triangles found when it began
    uint32_t stable = 0;
    bool draining = false;
    while (budgetLeft()) {
      if (draining && !border_.pending() && !reverse_.pending()) {
        if (!inFlight_.empty()) { // what the steps in flight found may be more to explore
          flush();
          continue;
        }
        if (found_.count() - iterationStart < cfg_.minNewTriangles) return;
        draining = false; // exploring the rest found enough to go on
        stable = 0;
      }
      const Step step = choose(draining);
      if (step == Step::Random) {
        if (result_.stats.randomRays >= iterationEnd) {
          // Triangles count once their step is in: a step in flight counts for the next iteration.
          const bool pending = border_.pending() || reverse_.pending() || !inFlight_.empty();
          if (result_.stats.iterations > 0) {
            stable = found_.count() - iterationStart < cfg_.minNewTriangles ? stable + 1 : 0;
            iterationStart = found_.count();
            if (stable >= cfg_.stableIterations) {
              if (!pending) return;
              draining = true;
              continue;
            }
          }
          if (result_.stats.iterations >= cfg_.maxIterations) return;
          ++result_.stats.iterations;
          iterationStart = found_.count();
          iterationEnd += randomPerIteration_;
        }
        randomStep(std::min<uint64_t>(step_, iterationEnd - result_.stats.randomRays));
      } else if (step == Step::Border) {
        borderStep();
      } else {
        reverseStep();
      }
      report();
    }
  }

  Step choose(bool draining) {
    const double border = border_.stage(std::max<size_t>(1, border_.chunkRays / border_.raysPerItem));
    const double reverse = reverse_.stage(std::max<size_t>(1, reverse_.chunkRays / reverse_.raysPerItem));
    if (result_.stats.randomRays < kWarmupSteps * step_ && !draining) return Step::Random;
    if (reverse_.size() > kMaxPendingSeeds) return Step::Reverse;
    if (border < 0.0 && reverse < 0.0) return Step::Random;
    const Step best = border >= reverse ? Step::Border : Step::Reverse;
    return draining || std::max(border, reverse) >= randomYield_ ? best : Step::Random;
  }

  void report() {
    if (!options_.progress) return;
    const PvsStats& s = result_.stats;
    options_.progress({.rays = s.rays,
                       .budget = cfg_.rayBudget,
                       .triangles = found_.count(),
                       .iterations = s.iterations,
                       .randomRays = s.randomRays,
                       .absRays = s.absRays,
                       .rsRays = s.rsRays,
                       .seconds = secondsSince(start_)});
  }

  void checkpoint() {
    // One snapshot however many requested counts this batch passed: rays strictly increase.
    bool reached = false;
    while (nextCheckpoint_ < options_.checkpointRays.size() &&
           result_.stats.rays >= options_.checkpointRays[nextCheckpoint_]) {
      reached = true;
      ++nextCheckpoint_;
    }
    if (reached) result_.checkpoints.push_back({result_.stats.rays, found_.sorted()});
  }

  bool budgetLeft() const { return cfg_.rayBudget == 0 || result_.stats.rays < cfg_.rayBudget; }
  uint64_t budgetClamp(uint64_t n) const {
    return cfg_.rayBudget == 0 ? n : std::min<uint64_t>(n, cfg_.rayBudget - result_.stats.rays);
  }

  // What finding `triangle` is worth: the solid angle it spans, unoccluded and at most a
  // hemisphere, averaged over the cell's corners and centre. Missing triangles cost pixels in
  // proportion to the solid angle they cover from wherever in the cell the view is, and random
  // rays find triangles at that rate too, so gains of every phase compare in one unit. Seen from
  // the discovering ray's origin alone, triangles near that origin were overrated by orders of
  // magnitude on wide cells, and border sampling (which finds the neighbours of what one origin
  // sees) looked several times better than random rays while losing to them in pixels.
  float discoveryValue(uint32_t triangle) const {
    constexpr float kHemisphere = 2.0f * std::numbers::pi_v<float>;
    auto tri = worldTriangle(scene_, offsets_, triangle);
    glm::vec3 n = glm::cross(tri[1] - tri[0], tri[2] - tri[0]); // twice the area, along the normal
    glm::vec3 centroid = (tri[0] + tri[1] + tri[2]) / 3.0f;
    float sum = 0.0f;
    for (glm::vec3 p : probes_) {
      glm::vec3 d = centroid - p;
      float d2 = glm::dot(d, d);
      float value = d2 > 0.0f ? std::abs(glm::dot(n, d)) / (2.0f * d2 * std::sqrt(d2)) : kHemisphere;
      sum += std::isfinite(value) ? std::min(value, kHemisphere) : 0.0f;
    }
    return sum / float(probes_.size());
  }

  // A triangle found for the first time by `ray`: queued for ABS, witnessed; returns its value.
  double discover(uint32_t triangle, const Ray& ray) {
    float value = discoveryValue(triangle);
    if (cfg_.adaptiveBorder) border_.queue.push({value, order_++, Discovery{triangle, ray.origin}});
    if (options_.keepWitnesses) result_.witnesses.push_back({triangle, ray});
    return value;
  }

  // Trace rays_[0, n) into hits_, recording into found_; every new discovery goes to discover().
  // Returns the value found.
  double traceAndCollect(size_t n) {
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
    double gain = 0.0;
    auto claim = [&](uint32_t t, size_t i) {
      if (t == kNoHit || (before_[t >> 6] >> (t & 63) & 1)) return;
      before_[t >> 6] |= uint64_t(1) << (t & 63); // later rays of the batch find it taken
      gain += discover(t, rays_[i]);
    };
    for (size_t i = 0; i < n; ++i) {
      claim(hits_[i].triangle, i);
      // Glass and cut-outs are discoveries too: ABS around them finds their frames, and its rays
      // pass through them to what lies behind.
      claim(hits_[i].seeThrough, i);
    }
    checkpoint();
    return gain;
  }

  // A step queued on the backend (submitCellRays / submitExploreRays) whose results are not in.
  struct InFlight {
    Step step = Step::Random;
    uint64_t base = 0;                          // random: Halton index of the first ray
    size_t rays = 0;                            // random: rays
    std::vector<Queued<Discovery>> discoveries; // border: the chunk
    std::vector<Queued<RsSeed>> seeds;          // reverse: the chunk
    std::vector<ExploreRaySource::BorderItem> borderItems;
    std::vector<ExploreRaySource::ReverseItem> reverseItems;
    ExploreRaySource src; // exploration: the chunk's rays (spans into the vectors above)
    double value = 0.0;   // exploration: the chunk's queued value
  };

  // Steps go to the backend's queue where it has one: while the device traces a step, the host
  // takes in the one before and chooses the next, so host work and tracing overlap. A step is
  // chosen with the results of all steps but the one in flight: the same choices whatever the
  // device's speed (bakes stay reproducible), and the same with a budget or checkpoints, where
  // the step in flight is taken in before the next is sized (exact ray counts, the same cut).
  // After a step was queued (begun at t0, handed to the backend at s0), the step before it comes in.
  using Clock = std::chrono::steady_clock;
  void submitted(Clock::time_point t0, Clock::time_point s0, double& phaseSeconds, double& phaseTraceSeconds) {
    const double inBackend = secondsSince(s0);
    result_.stats.traceSeconds += inBackend;
    phaseTraceSeconds += inBackend;
    phaseSeconds += secondsSince(t0);
    while (inFlight_.size() > 1) finishOldest();
  }
  void flush() {
    while (!inFlight_.empty()) finishOldest();
  }
  // Before a step is sized: in a bake with a budget or checkpoints, the steps in flight come in
  // first. False when the budget is spent.
  bool readyToSize() {
    if (!overlap_) flush();
    return budgetLeft();
  }

  void finishOldest() {
    InFlight f = std::move(inFlight_.front());
    inFlight_.pop_front();
    auto t0 = std::chrono::steady_clock::now();
    backend_.collect(found_, explored_);
    const double waited = secondsSince(t0);
    result_.stats.traceSeconds += waited;
    result_.stats.rays += explored_.traced;
    // Atomics append in scheduling order: sort to the order the host path credits them in.
    auto byRay = [](const FirstHit& a, const FirstHit& b) {
      return a.ray != b.ray ? a.ray < b.ray : a.triangle < b.triangle;
    };
    std::sort(explored_.firstHits.begin(), explored_.firstHits.end(), byRay);
    double gain = 0.0;
    if (f.step == Step::Random) {
      result_.stats.randomTraceSeconds += waited;
      // The discovering ray rebuilt from its Halton index (the same map, in float on both sides:
      // the origin agrees to rounding, which ABS does not notice).
      for (const FirstHit& h : explored_.firstHits) {
        auto p = halton_(f.base + h.ray);
        Ray ray{};
        ray.origin = surface_.point(p[0], p[1], p[2]);
        ray.dir = detail::sphereDirection(p[3], p[4]);
        gain += discover(h.triangle, ray);
      }
      checkpoint();
      randomYield_ = f.rays ? gain / double(f.rays) : 0.0;
      result_.stats.randomSeconds += secondsSince(t0);
      return;
    }
    for (const FirstHit& h : explored_.firstHits)
      gain += discover(h.triangle, detail::exploreRay(scene_, offsets_, f.src, h.ray));
    checkpoint();
    if (f.step == Step::Border) {
      result_.stats.absTraceSeconds += waited;
      result_.stats.absRays += explored_.traced;
      queueSeeds(f);
      border_.record(f.value, gain, step_);
      result_.stats.absSeconds += secondsSince(t0);
    } else {
      result_.stats.rsTraceSeconds += waited;
      result_.stats.rsRays += explored_.traced;
      reverse_.record(f.value, gain, step_);
      result_.stats.rsSeconds += secondsSince(t0);
    }
  }

  // The discontinuities of a border chunk traced on the device, queued for RS: the seeds as
  // queueSeed would queue them one by one, made on all cores and queued as one run: in ray order
  // they are in priority order already (the chunk's items are, and the insertion order grows with
  // the ray), so the queue need not check or sort them.
  void queueSeeds(const InFlight& f) {
    const size_t slots = f.discoveries.size() * f.src.raysPerItem;
    inRayOrder(explored_.discontinuities, slots, discontinuities_);
    result_.stats.discontinuities += discontinuities_.size();
    if (!cfg_.reverseSampling || cfg_.rsEdgeSamples + cfg_.rsAreaSamples == 0) return;
    std::vector<Queued<RsSeed>> run(discontinuities_.size());
    const uint64_t first = order_;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, run.size(), 1 << 14), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t k = r.begin(); k < r.end(); ++k) {
        const Discontinuity& d = discontinuities_[k];
        run[k] = {f.discoveries[d.ray / f.src.raysPerItem].value, first + k, RsSeed{d.target, d.occluder}};
      }
    });
    order_ += run.size();
    reverse_.queue.pushRun(std::move(run));
  }

  // `n` rays of the cell's one randomized Halton sequence (the same rays for the same seed as the
  // RAND baseline's, so the two differ only in what GVS++ does besides).
  void randomStep(uint64_t count) {
    if (!readyToSize()) return;
    auto t0 = std::chrono::steady_clock::now();
    phaseTrace_ = &result_.stats.randomTraceSeconds;
    size_t n = size_t(budgetClamp(count));
    // Random rays alone (RAND) end their steps at the requested checkpoints, so RAND's snapshots
    // fall exactly where GVS++'s did (pvs-eval --plot compares them at equal rays); the rays are
    // the same either way. GVS++'s steps are not cut: that would change its schedule.
    if (!cfg_.adaptiveBorder && nextCheckpoint_ < options_.checkpointRays.size() &&
        options_.checkpointRays[nextCheckpoint_] > result_.stats.rays)
      n = size_t(std::min<uint64_t>(n, options_.checkpointRays[nextCheckpoint_] - result_.stats.rays));
    // Generated rays cost no per-ray traffic: the backend makes them where it traces them, and
    // only first discoveries come back.
    const auto s0 = std::chrono::steady_clock::now();
    if (generate_ && queue_ &&
        backend_.submitCellRays({surface_.faces, surface_.cdf, halton_.offsets(), haltonIndex_}, n, found_)) {
      result_.stats.generatedRandomRays = true;
      inFlight_.push_back({.step = Step::Random, .base = haltonIndex_, .rays = n});
      haltonIndex_ += n;
      result_.stats.randomRays += n;
      submitted(t0, s0, result_.stats.randomSeconds, result_.stats.randomTraceSeconds);
      return;
    }
    generate_ = false; // the backend cannot: make the rays here from now on
    flush();
    rays_.resize(n);
    hits_.resize(n);
    const uint64_t base = haltonIndex_;
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
    const double gain = traceAndCollect(n);
    haltonIndex_ += n;
    result_.stats.randomRays += n;
    randomYield_ = n ? gain / double(n) : 0.0;
    result_.stats.randomSeconds += secondsSince(t0);
  }

  // The chunk's exploration rays as the backend takes them: ABS around discoveries (the
  // border-polygon formulas of shaderio/gvs_explore.h) or RS from the cell towards discontinuities.
  ExploreRaySource exploreSource(const std::vector<Queued<Discovery>>& items,
                                 std::vector<ExploreRaySource::BorderItem>& out) {
    ExploreRaySource src = exploreSource();
    src.kind = ExploreRaySource::Kind::Border;
    out.clear();
    for (const auto& q : items) out.push_back({q.item.origin, q.item.triangle});
    src.border = out;
    src.raysPerItem = uint32_t(border_.raysPerItem);
    return src;
  }
  ExploreRaySource exploreSource(const std::vector<Queued<RsSeed>>& items,
                                 std::vector<ExploreRaySource::ReverseItem>& out) {
    ExploreRaySource src = exploreSource();
    src.kind = ExploreRaySource::Kind::Reverse;
    out.clear();
    for (const auto& q : items) out.push_back({q.item.target, q.item.occluder});
    src.reverse = out;
    src.raysPerItem = uint32_t(reverse_.raysPerItem);
    return src;
  }
  ExploreRaySource exploreSource() const {
    ExploreRaySource src;
    src.edges = edges_;
    src.faces = surface_.faces;
    src.cdf = surface_.cdf;
    src.absEdgeSamples = cfg_.absEdgeSamples;
    src.absDeltaTriangle = cfg_.absDeltaTriangle;
    src.absDeltaAbsolute = cfg_.absDeltaScene * sceneDiagonal_;
    src.rsDeltaRelative = cfg_.rsDeltaRelative;
    src.rsEdgeSamples = cfg_.rsEdgeSamples;
    src.rsAreaSamples = cfg_.rsAreaSamples;
    src.rsOffset = rsHalton_.offsets();
    src.firstSeed = rsIndex_;
    return src;
  }

  // The chunk queued where the backend makes its rays: only discoveries and discontinuities come
  // back (finishOldest). False when the backend cannot, or the budget would cut the chunk (the
  // host path cuts it ray by ray); then the host makes the rays.
  bool submitExplore(InFlight&& f) {
    const size_t slots = (f.src.border.size() + f.src.reverse.size()) * f.src.raysPerItem;
    if (!queue_ || !deviceExplore_ || (cfg_.rayBudget != 0 && result_.stats.rays + slots > cfg_.rayBudget))
      return false;
    if (!backend_.submitExploreRays(f.src, found_)) {
      deviceExplore_ = false; // the backend cannot: make the rays here from now on
      return false;
    }
    result_.stats.generatedExploreRays = true;
    inFlight_.push_back(std::move(f));
    return true;
  }

  // `found` (at most one per ray, rays below `slots`) in ray order: placed by ray index, which
  // costs less than sorting the hundreds of thousands a border chunk can meet, on all cores (each
  // block of slots is compacted to where the blocks before it end: the same order on any number).
  void inRayOrder(const std::vector<Discontinuity>& found, size_t slots, std::vector<Discontinuity>& out) {
    constexpr size_t kBlock = size_t(1) << 15;
    const size_t blocks = (slots + kBlock - 1) / kBlock;
    slotOf_.resize(slots);
    blockStart_.assign(blocks + 1, 0);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, slots, kBlock), [&](const tbb::blocked_range<size_t>& r) {
      std::fill(slotOf_.begin() + ptrdiff_t(r.begin()), slotOf_.begin() + ptrdiff_t(r.end()), ~0u);
    });
    tbb::parallel_for(tbb::blocked_range<size_t>(0, found.size(), kBlock), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t k = r.begin(); k < r.end(); ++k) slotOf_[found[k].ray] = uint32_t(k); // rays are distinct
    });
    tbb::parallel_for(size_t(0), blocks, [&](size_t b) {
      const size_t end = std::min(slots, (b + 1) * kBlock);
      blockStart_[b + 1] = size_t(std::count_if(slotOf_.begin() + ptrdiff_t(b * kBlock),
                                                slotOf_.begin() + ptrdiff_t(end), [](uint32_t k) { return k != ~0u; }));
    });
    for (size_t b = 0; b < blocks; ++b) blockStart_[b + 1] += blockStart_[b];
    out.resize(blockStart_[blocks]);
    tbb::parallel_for(size_t(0), blocks, [&](size_t b) {
      size_t o = blockStart_[b];
      for (size_t i = b * kBlock; i < std::min(slots, (b + 1) * kBlock); ++i)
        if (slotOf_[i] != ~0u) out[o++] = found[slotOf_[i]];
    });
  }

  // The chunk's rays made here into fixed slots (one block per item), the skipped ones squeezed
  // out, so every traced ray is a real sample; `owner_` (the item a ray belongs to) and, for ABS,
  // `targets_` move along.
  void makeRays(const ExploreRaySource& src) {
    const size_t slots = (src.border.size() + src.reverse.size()) * src.raysPerItem;
    const bool border = src.kind == ExploreRaySource::Kind::Border;
    rays_.resize(slots);
    targets_.resize(border ? slots : 0);
    detail::makeExploreRays(scene_, offsets_, src, rays_, targets_);
    size_t out = 0;
    owner_.resize(slots);
    for (size_t i = 0; i < slots; ++i) {
      if (rays_[i].tfar < 0.0f) continue;
      rays_[out] = rays_[i];
      owner_[out] = uint32_t(i / src.raysPerItem);
      if (border) targets_[out] = targets_[i];
      ++out;
    }
    rays_.resize(out);
    owner_.resize(out);
    if (border) targets_.resize(out);
  }

  // A discontinuity found by ABS: queued for RS, worth what the triangle whose border it lies on was.
  void queueSeed(float value, glm::vec3 target, uint32_t occluder) {
    ++result_.stats.discontinuities;
    if (cfg_.reverseSampling && cfg_.rsEdgeSamples + cfg_.rsAreaSamples > 0)
      reverse_.queue.push({value, order_++, RsSeed{target, occluder}});
  }

  // ABS on the staged chunk of discoveries; the discontinuities its rays meet are queued for RS.
  void borderStep() {
    if (!readyToSize()) return;
    auto t0 = std::chrono::steady_clock::now();
    phaseTrace_ = &result_.stats.absTraceSeconds;
    InFlight f{.step = Step::Border};
    f.discoveries = std::move(border_.staged);
    border_.staged.clear();
    for (const auto& q : f.discoveries) f.value += q.value;
    f.src = exploreSource(f.discoveries, f.borderItems);
    const auto s0 = std::chrono::steady_clock::now();
    if (submitExplore(std::move(f))) {
      submitted(t0, s0, result_.stats.absSeconds, result_.stats.absTraceSeconds);
      return;
    }
    flush();
    const std::vector<Queued<Discovery>>& items = f.discoveries; // not moved from: submitExplore failed
    makeRays(f.src);
    const uint64_t traced = budgetClamp(rays_.size());
    hits_.resize(rays_.size());
    const double gain = traceAndCollect(size_t(traced));
    for (size_t i = 0; i < traced; ++i) {
      float dist = glm::length(targets_[i] - rays_[i].origin);
      if (hits_[i].triangle != kNoHit && hits_[i].t >= dist * (1.0f - cfg_.rsDeltaRelative)) continue;
      queueSeed(items[owner_[i]].value, targets_[i], hits_[i].triangle);
    }
    result_.stats.absRays += traced;
    border_.record(f.value, gain, step_);
    result_.stats.absSeconds += secondsSince(t0);
  }

  // RS on the staged chunk of seeds: origins spread over the cell, aimed at each seed's target.
  void reverseStep() {
    if (!readyToSize()) return;
    auto t0 = std::chrono::steady_clock::now();
    phaseTrace_ = &result_.stats.rsTraceSeconds;
    InFlight f{.step = Step::Reverse};
    f.seeds = std::move(reverse_.staged);
    reverse_.staged.clear();
    for (const auto& q : f.seeds) f.value += q.value;
    f.src = exploreSource(f.seeds, f.reverseItems);
    const size_t items = f.seeds.size();
    const auto s0 = std::chrono::steady_clock::now();
    if (submitExplore(std::move(f))) {
      rsIndex_ += items;
      submitted(t0, s0, result_.stats.rsSeconds, result_.stats.rsTraceSeconds);
      return;
    }
    flush();
    makeRays(f.src);
    const uint64_t traced = budgetClamp(rays_.size());
    hits_.resize(rays_.size());
    const double gain = traceAndCollect(size_t(traced));
    rsIndex_ += items;
    result_.stats.rsRays += traced;
    reverse_.record(f.value, gain, step_);
    result_.stats.rsSeconds += secondsSince(t0);
  }

  RayBackend& backend_;
  const Scene& scene_;
  const GvsConfig& cfg_;
  const BakeOptions& options_;
  std::vector<uint64_t> offsets_;
  TriangleSet found_;
  detail::SurfaceSampler surface_;
  RandomizedHalton<5> halton_; // face, u, v, direction u, direction v
  RandomizedHalton<3> rsHalton_;
  const uint64_t randomPerIteration_;
  // Rays per step: the backend's batch (256 k fill all CPU cores), at most one iteration's random
  // rays, so a budget of a few iterations is still spent in many decisions.
  const size_t step_;
  uint64_t haltonIndex_ = 0;
  uint64_t rsIndex_ = 0;
  uint64_t order_ = 0; // queue insertions so far (ties in value go first-in first-out)
  Explorer<Discovery> border_;
  Explorer<RsSeed> reverse_;
  double randomYield_ = 0.0; // value found per ray by the last random step
  size_t nextCheckpoint_ = 0;
  bool generate_ = true;      // try the backend's own random rays (submitCellRays) first
  bool deviceExplore_ = true; // and its own ABS and RS rays (submitExploreRays)
  bool queue_ = false;        // the backend queues traces (maxQueued)
  bool overlap_ = true;       // no budget or checkpoints: the next step is queued before the last is in
  std::deque<InFlight> inFlight_;
  ExploreResult explored_;
  std::vector<Discontinuity> discontinuities_;
  std::vector<uint32_t> slotOf_;   // the discontinuity of each slot of a border chunk (~0u: none)
  std::vector<size_t> blockStart_; // inRayOrder: where each block of slots goes in its output
  bool traceable_ = true;
  double* phaseTrace_ = nullptr; // the current phase's share of the trace time
  float sceneDiagonal_ = 1.0f;
  std::vector<std::array<glm::vec3, 2>> edges_;
  std::vector<glm::vec3> probes_; // where discoveryValue looks from: the cell's corners and centre
  std::vector<Ray> rays_;
  std::vector<Hit> hits_;
  std::vector<uint32_t> owner_;    // the queued item each ray of a step belongs to
  std::vector<glm::vec3> targets_; // the border point each ABS ray aims at (host-made rays)
  std::vector<uint64_t> before_;   // found_ before the current batch, plus the batch's claims
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
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
