#pragma once
// GPU residency of paged cluster DAGs (docs/lod.md, "Residency"): which pages a byte budget keeps
// resident, decided on the CPU from the GPU selection's feedback. Plain data, no Vulkan: the
// renderer (render/cluster_residency.cpp) uploads what a step loads and frees what it evicts.
//
// Every frame the selection writes, per page, the largest shaderio::pageRequestPriority it met
// (residencyFeedback is the CPU reference): for a missing page the request of a drawn cluster whose
// children it holds, for a resident page its use by the cut (a member group above the threshold).
// A step takes the requests by priority, each with its missing dependencies first, as long as
// uploads remain this step, and makes room by eviction: never a root page, never a page another
// resident page depends on (the resident set stays closed, so every cut is crack-free, docs/lod.md
// "Paging"); pages the last feedback did not use first (least recently used first, then lowest
// priority), then used pages of lower priority than the request. A request that cannot fit is
// left for later (counted).
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/lod/cluster_dag.h"
#include "mirage/lod/paging.h"

namespace mirage::lod {

// The pages of one or more paged meshes numbered as one: mesh m's page p is page pageOffset[m] + p.
struct ResidencyGraph {
  std::vector<uint32_t> pageOffset;       // per mesh: its first page
  std::vector<uint64_t> bytes;            // per page: the bytes it takes while resident
  std::vector<uint8_t> root;              // per page: always resident
  std::vector<uint32_t> dependencyOffset; // per page + 1: range in `dependencies`
  std::vector<uint32_t> dependencies;     // pages that must be resident while it is (numbered as one)

  uint32_t pageCount() const { return uint32_t(bytes.size()); }
  std::span<const uint32_t> dependenciesOf(uint32_t page) const {
    return {dependencies.data() + dependencyOffset[page], dependencyOffset[page + 1] - dependencyOffset[page]};
  }
};

// The graph of `tables` (one per mesh) with every page taking `pageBytes(mesh, page)` bytes.
template <class PageBytes>
ResidencyGraph residencyGraph(std::span<const PageTable* const> tables, PageBytes pageBytes) {
  ResidencyGraph g;
  g.dependencyOffset.push_back(0);
  for (uint32_t m = 0; m < tables.size(); ++m) {
    const PageTable& t = *tables[m];
    uint32_t base = uint32_t(g.bytes.size());
    g.pageOffset.push_back(base);
    for (uint32_t p = 0; p < t.pages.size(); ++p) {
      g.bytes.push_back(pageBytes(m, p));
      g.root.push_back(p < t.rootPageCount ? 1 : 0);
      for (uint32_t d : t.dependenciesOf(p)) g.dependencies.push_back(base + d);
      g.dependencyOffset.push_back(uint32_t(g.dependencies.size()));
    }
  }
  return g;
}

struct ResidencyConfig {
  uint64_t budgetBytes = 0;      // resident pages never take more
  uint32_t maxLoadsPerStep = 16; // page uploads per step (a frame), dependencies included
};

// What one step decided: evictions first, then loads in order (each page after its dependencies).
struct ResidencyStep {
  std::vector<uint32_t> evicted;
  std::vector<uint32_t> loaded;
  uint32_t requested = 0; // missing pages the feedback asked for
  uint32_t unfit = 0;     // of those, left for later: no room within the budget (uploads aside)
};

class ResidencyManager {
public:
  // The root pages resident; an error when they alone exceed the budget.
  static Result<ResidencyManager> create(ResidencyGraph graph, const ResidencyConfig& config);

  // One frame's feedback (per page, 0 = nothing): uses of resident pages, requests for missing ones.
  ResidencyStep step(std::span<const float> feedback);

  // Sets what `page` takes while resident: a cost first estimated from the page table and exact once
  // the page is read. A resident page's cost may only shrink (the budget keeps holding).
  void setPageBytes(uint32_t page, uint64_t bytes);

  const ResidencyGraph& graph() const { return graph_; }
  const ResidencyConfig& config() const { return config_; }
  std::span<const uint8_t> resident() const { return resident_; }
  bool isResident(uint32_t page) const { return resident_[page] != 0; }
  uint64_t residentBytes() const { return residentBytes_; }
  uint32_t residentPages() const { return residentPages_; }
  uint64_t frame() const { return frame_; }
  // Every root resident, every dependency of a resident page resident, within the budget.
  bool consistent() const;

private:
  ResidencyManager(ResidencyGraph graph, const ResidencyConfig& config);
  void load(uint32_t page, float priority);
  void evict(uint32_t page);
  // An eviction candidate as the step found it: the order plan() walks is fixed when the step's
  // first eviction is planned (unused before used, least recently used, lowest priority, finest).
  struct Candidate {
    uint32_t page;
    bool used;      // in the feedback of this step (lastUsed_ == frame_) when sorted
    float priority; // usePriority_ when sorted
  };
  // Pages to evict (in order) so that `need` more bytes fit, for a request of `priority`; empty
  // when they cannot be found. Walks `candidates` (the step's resident pages other than roots, in
  // eviction order) and keeps the pages with keptStamp_ == stamp_ (the request's dependency
  // closure): its cost does not grow with the scene's pages (scenes have 100 000 and more).
  std::vector<uint32_t> plan(uint64_t need, float priority, std::span<const Candidate> candidates);
  ResidencyGraph graph_;
  ResidencyConfig config_;
  std::vector<uint8_t> resident_;
  std::vector<uint32_t> residentDependents_; // per page: resident pages depending on it
  std::vector<uint64_t> lastUsed_;           // per page: the last step whose feedback used (or loaded) it
  std::vector<float> usePriority_;           // per page: its priority then
  uint64_t residentBytes_ = 0;
  uint32_t residentPages_ = 0;
  uint64_t frame_ = 0;
  // The resident pages in no particular order, and each one's place in it (swap-removed on evict).
  std::vector<uint32_t> residentList_, residentAt_;
  // Per page: the request whose dependency closure holds it, and the plan that chose it (stamps, so
  // nothing is cleared per request).
  std::vector<uint32_t> keptStamp_, goneStamp_;
  uint32_t stamp_ = 0, planStamp_ = 0;
};

// The CPU reference of the GPU selection's feedback for one mesh under `view` (no frustum): per
// page of `table`, the largest pageRequestPriority of a resident cluster asking for it
// (residentCutRequests), or for a resident page of a resident cluster of it whose member group is
// above the threshold (roots: +inf).
std::vector<float> residencyFeedback(const ClusterDag& dag, const PageTable& table, std::span<const uint8_t> resident,
                                     const CutView& view);

// Prefetch: per page of `table`, the priority wantedPages gives it under `view` with nothing but
// the root pages resident (0 for a page the full cut does not need; roots are left to the
// feedback). Merged into a frame's feedback (mergeFeedback), a step asks for the pages of every
// level the view needs at once, each after its dependencies (priorities descend along them),
// instead of one level per round trip; the resident pages it needs count as used. The full cut
// needs no other page, so what converges is the same cut. With `planes` (object space, inside:
// dot(plane, (x, 1)) >= 0, world-unit distances for a transformed mesh), a group whose sphere,
// radius times `radiusScale` (the instance's largest axis scale), lies wholly outside one is not
// wanted (the selection culls it).
std::vector<float> prefetchFeedback(const PageTable& table, const CutView& view, std::span<const glm::vec4> planes = {},
                                    float radiusScale = 1.0f);
// feedback[offset + p] = max(feedback[offset + p], prefetch[p]): one mesh's prefetch into the
// feedback of pages numbered as one (ResidencyGraph::pageOffset).
void mergeFeedback(std::span<float> feedback, std::span<const float> prefetch, uint32_t offset = 0);

} // namespace mirage::lod
