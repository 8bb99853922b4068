// The residency manager of paged cluster DAGs (docs/lod.md, "Residency").
#include "mirage/lod/residency.h"

#include <algorithm>
#include <cassert>
#include <limits>

#include <fmt/format.h>

#include "mirage/shaderio/lod_paging.h"

namespace mirage::lod {

ResidencyManager::ResidencyManager(ResidencyGraph graph, const ResidencyConfig& config)
    : graph_(std::move(graph)), config_(config) {
  uint32_t n = graph_.pageCount();
  resident_.assign(n, 0);
  residentDependents_.assign(n, 0);
  lastUsed_.assign(n, 0);
  usePriority_.assign(n, 0.0f);
  residentAt_.assign(n, 0);
  keptStamp_.assign(n, 0);
  goneStamp_.assign(n, 0);
}

Result<ResidencyManager> ResidencyManager::create(ResidencyGraph graph, const ResidencyConfig& config) {
  uint64_t rootBytes = 0;
  for (uint32_t p = 0; p < graph.pageCount(); ++p)
    if (graph.root[p]) rootBytes += graph.bytes[p];
  if (rootBytes > config.budgetBytes)
    return Error{fmt::format("a GPU budget of {} bytes is below the root pages' {} bytes (always resident)",
                             config.budgetBytes, rootBytes)};
  ResidencyManager m(std::move(graph), config);
  for (uint32_t p = 0; p < m.graph_.pageCount(); ++p)
    if (m.graph_.root[p]) m.load(p, std::numeric_limits<float>::infinity());
  return m;
}

void ResidencyManager::load(uint32_t page, float priority) {
  resident_[page] = 1;
  residentAt_[page] = uint32_t(residentList_.size());
  residentList_.push_back(page);
  residentBytes_ += graph_.bytes[page];
  ++residentPages_;
  for (uint32_t d : graph_.dependenciesOf(page)) ++residentDependents_[d];
  lastUsed_[page] = frame_;
  usePriority_[page] = priority;
}

void ResidencyManager::setPageBytes(uint32_t page, uint64_t bytes) {
  assert(!resident_[page] || bytes <= graph_.bytes[page]);
  if (resident_[page]) residentBytes_ = residentBytes_ - graph_.bytes[page] + bytes;
  graph_.bytes[page] = bytes;
}

void ResidencyManager::evict(uint32_t page) {
  resident_[page] = 0;
  uint32_t at = residentAt_[page], last = residentList_.back();
  residentList_[at] = last, residentAt_[last] = at;
  residentList_.pop_back();
  residentBytes_ -= graph_.bytes[page];
  --residentPages_;
  for (uint32_t d : graph_.dependenciesOf(page)) --residentDependents_[d];
}

std::vector<uint32_t> ResidencyManager::plan(uint64_t need, float priority, std::span<const Candidate> candidates) {
  if (++planStamp_ == 0) {
    std::fill(goneStamp_.begin(), goneStamp_.end(), 0);
    planStamp_ = 1;
  }
  // Evictions are simulated: evicting a page may free its dependencies for eviction. The few pages
  // whose resident dependents the simulated victims reduce keep their count here.
  std::vector<std::pair<uint32_t, uint32_t>> freedDependents; // (page, dependents simulated gone)
  auto dependentsLeft = [&](uint32_t p) {
    uint32_t n = residentDependents_[p];
    for (auto [q, c] : freedDependents)
      if (q == p) n -= c;
    return n;
  };
  std::vector<uint32_t> out;
  uint64_t freed = 0;
  while (freed < need) {
    // The first eligible candidate in eviction order is the best one. Once the used pages reach the
    // request's priority, every later one is as needed as the request (sorted by priority).
    uint32_t best = ~0u;
    for (const Candidate& c : candidates) {
      if (c.used && c.priority >= priority) break;
      uint32_t p = c.page;
      if (!resident_[p] || keptStamp_[p] == stamp_ || goneStamp_[p] == planStamp_) continue;
      if (lastUsed_[p] == frame_ && usePriority_[p] >= priority) continue; // loaded again this step
      if (residentDependents_[p] != 0 && (freedDependents.empty() || dependentsLeft(p) != 0)) continue;
      best = p;
      break;
    }
    if (best == ~0u) return {};
    goneStamp_[best] = planStamp_;
    for (uint32_t d : graph_.dependenciesOf(best)) {
      auto it = std::find_if(freedDependents.begin(), freedDependents.end(), [&](auto& e) { return e.first == d; });
      if (it == freedDependents.end())
        freedDependents.push_back({d, 1});
      else
        ++it->second;
    }
    freed += graph_.bytes[best];
    out.push_back(best);
  }
  return out;
}

ResidencyStep ResidencyManager::step(std::span<const float> feedback) {
  ++frame_;
  ResidencyStep out;
  std::vector<std::pair<float, uint32_t>> requests;
  for (uint32_t p = 0; p < graph_.pageCount() && p < feedback.size(); ++p) {
    if (!(feedback[p] > 0.0f)) continue;
    if (resident_[p]) {
      lastUsed_[p] = frame_;
      usePriority_[p] = feedback[p];
    } else {
      requests.push_back({feedback[p], p});
    }
  }
  out.requested = uint32_t(requests.size());
  std::stable_sort(requests.begin(), requests.end(), [](auto& a, auto& b) { return a.first > b.first; });
  std::vector<uint32_t> closure, stack;
  // Eviction candidates: the resident pages other than roots when the first eviction is planned.
  // Pages loaded later in this step are never victims of it (their priority is at least that of
  // every later request, which come in descending order).
  std::vector<Candidate> candidates;
  bool haveCandidates = false;
  for (auto [priority, page] : requests) {
    if (resident_[page]) continue; // loaded as a dependency of an earlier request
    if (out.loaded.size() >= config_.maxLoadsPerStep) {
      ++out.unfit; // no uploads left this step (its closure holds the page itself): asked again next frame
      continue;
    }
    // The request's dependency closure: what it keeps, and the missing pages to load (ascending
    // within a mesh: dependencies have lower page numbers).
    if (++stamp_ == 0) { // wrapped: clear once in four billion requests
      std::fill(keptStamp_.begin(), keptStamp_.end(), 0);
      stamp_ = 1;
    }
    closure.clear();
    stack.assign(1, page);
    keptStamp_[page] = stamp_;
    while (!stack.empty()) {
      uint32_t p = stack.back();
      stack.pop_back();
      if (!resident_[p]) closure.push_back(p);
      for (uint32_t d : graph_.dependenciesOf(p))
        if (keptStamp_[d] != stamp_) keptStamp_[d] = stamp_, stack.push_back(d);
    }
    if (out.loaded.size() + closure.size() > config_.maxLoadsPerStep) {
      ++out.unfit; // no uploads left this step: asked again next frame
      continue;
    }
    std::sort(closure.begin(), closure.end());
    uint64_t bytes = 0;
    for (uint32_t p : closure) bytes += graph_.bytes[p];
    uint64_t free = config_.budgetBytes - residentBytes_;
    if (bytes > free) {
      // Pages loaded this step are kept too (lastUsed = this frame, the request's priority).
      if (!haveCandidates) { // eviction order: unused first, least recently used, lowest priority, finest
        for (uint32_t p : residentList_)
          if (!graph_.root[p]) candidates.push_back({p, lastUsed_[p] == frame_, usePriority_[p]});
        std::sort(candidates.begin(), candidates.end(), [&](const Candidate& a, const Candidate& b) {
          if (a.used != b.used) return !a.used;
          if (lastUsed_[a.page] != lastUsed_[b.page]) return lastUsed_[a.page] < lastUsed_[b.page];
          if (a.priority != b.priority) return a.priority < b.priority;
          return a.page > b.page;
        });
        haveCandidates = true;
      }
      std::vector<uint32_t> victims = plan(bytes - free, priority, candidates);
      if (victims.empty()) {
        ++out.unfit;
        continue;
      }
      for (uint32_t v : victims) evict(v);
      out.evicted.insert(out.evicted.end(), victims.begin(), victims.end());
    }
    for (uint32_t p : closure) load(p, priority);
    out.loaded.insert(out.loaded.end(), closure.begin(), closure.end());
  }
  return out;
}

bool ResidencyManager::consistent() const {
  uint64_t bytes = 0;
  for (uint32_t p = 0; p < graph_.pageCount(); ++p) {
    if (graph_.root[p] && !resident_[p]) return false;
    if (!resident_[p]) continue;
    bytes += graph_.bytes[p];
    for (uint32_t d : graph_.dependenciesOf(p))
      if (!resident_[d]) return false;
  }
  return bytes == residentBytes_ && bytes <= config_.budgetBytes;
}

std::vector<float> residencyFeedback(const ClusterDag& dag, const PageTable& table, std::span<const uint8_t> resident,
                                     const CutView& view) {
  std::vector<float> out(table.pages.size(), 0.0f);
  for (uint32_t c = 0; c < dag.clusters.size(); ++c) {
    uint32_t page = table.clusterPage[c];
    if (!resident[page]) continue;
    const Cluster& cl = dag.clusters[c];
    uint32_t childPage = table.childPage(cl.generatingGroup);
    float self = cl.generatingGroup == kNone ? 0.0f : projectedError(table.groupBounds[cl.generatingGroup], view);
    float parent =
        cl.group == kNone ? std::numeric_limits<float>::infinity() : projectedError(table.groupBounds[cl.group], view);
    bool selfWithin = self <= view.tau, parentAbove = parent > view.tau;
    bool childrenResident = childPage != kNone && resident[childPage];
    if (parentAbove) out[page] = std::max(out[page], shaderio::pageRequestPriority(parent, view.tau));
    if (childPage != kNone && shaderio::residentCutRequests(selfWithin, parentAbove, childrenResident))
      out[childPage] = std::max(out[childPage], shaderio::pageRequestPriority(self, view.tau));
  }
  return out;
}

std::vector<float> prefetchFeedback(const PageTable& table, const CutView& view, std::span<const glm::vec4> planes,
                                    float radiusScale) {
  // wantedPages with the root pages resident, groups outside the planes left out.
  std::vector<float> out(table.pages.size(), 0.0f);
  for (uint32_t g = 0; g < table.groupBounds.size() && g < table.groupPage.size(); ++g) {
    const LodBounds& b = table.groupBounds[g];
    bool outside = false;
    for (const glm::vec4& plane : planes)
      outside = outside || glm::dot(plane, glm::vec4(b.center, 1.0f)) < -b.radius * radiusScale;
    if (outside) continue;
    float e = projectedError(b, view);
    if (e > view.tau) {
      float& p = out[table.groupPage[g]];
      p = std::max(p, shaderio::pageRequestPriority(e, view.tau));
    }
  }
  for (uint32_t p = uint32_t(table.pages.size()); p-- > 0;) // dependencies have lower indices
    if (out[p] > 0.0f)
      for (uint32_t d : table.dependenciesOf(p)) out[d] = std::max(out[d], out[p]);
  for (uint32_t p = 0; p < table.rootPageCount && p < out.size(); ++p) out[p] = 0.0f;
  return out;
}

void mergeFeedback(std::span<float> feedback, std::span<const float> prefetch, uint32_t offset) {
  for (size_t p = 0; p < prefetch.size() && offset + p < feedback.size(); ++p)
    feedback[offset + p] = std::max(feedback[offset + p], prefetch[p]);
}

} // namespace mirage::lod
