#pragma once
// Paged cluster DAG (docs/lod.md, "Paging"): the DAG's groups assigned to fixed-budget pages (whole
// groups, coarse to fine, Morton order within a level; the roots in always-resident root pages), the
// page dependencies that keep a residency-aware cut crack-free, the cut itself and the request rule
// (shaderio/lod_paging.h, shared with the GPU), and the standalone encoding of each page plus the
// page table. Plain data and free functions; the container stores the bytes.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "mirage/core/result.h"
#include "mirage/lod/cluster_dag.h"

namespace mirage::lod {

inline constexpr uint32_t kPageCodecVersion = 1;

struct PageConfig {
  // Encoded bytes per page (before the container's compression). A page holds whole groups, so a
  // group larger than this gets a page of its own. 128 KiB (docs/lod.md, "Paging"): the dragon's
  // groups encode to about 40 KiB (32 clusters, levels 0-1: 85 % of its groups), 80 KiB (64
  // clusters, levels 2-3) and 145 KiB (128 clusters, levels 4-6), so fine pages hold three groups
  // and only the coarsest groups, which every view of the mesh wants, overflow (7 of 159 pages,
  // 83.5 % mean fill); 192 KiB removes those but makes the fine levels' residency 1.5x coarser,
  // 64 KiB leaves a group alone in nearly every page (71 % fill, 50 pages over).
  uint32_t pageBytes = 128 * 1024;
  // Bits per position axis, as DagEncodeOptions::positionBits: the page codec picks the same grid
  // as the CDAG chunk, so positions and bounds decode bit for bit alike from either.
  uint32_t positionBits = 16;
};

struct PageInfo {
  uint32_t groupOffset = 0; // range in PageTable::pageGroups (root pages hold no group)
  uint32_t groupCount = 0;
  uint32_t clusterOffset = 0; // range in PageTable::pageClusters: DAG cluster ids in the page's order
  uint32_t clusterCount = 0;
  // Range in PageTable::dependencies: the pages that must be resident while this one is, all of
  // lower index (so page order is a load order).
  uint32_t dependencyOffset = 0;
  uint32_t dependencyCount = 0;
  uint32_t vertexCount = 0; // page-local vertices: the attribute vertices of its clusters, each once
  uint32_t triangleCount = 0;
  uint32_t bytes = 0; // encoded size
};

struct PageTable {
  // The position grid of every page (the CDAG chunk's): bits per axis (32: raw floats), origin, step.
  uint32_t positionBits = 32;
  glm::vec3 gridOrigin{0.0f};
  float gridStep = 1.0f;
  bool hasNormals = false;
  bool hasUv = false;
  // Pages [0, rootPageCount) hold the root clusters: always resident.
  uint32_t rootPageCount = 0;
  std::vector<PageInfo> pages; // root pages, then the groups' pages coarse to fine
  std::vector<uint32_t> pageGroups;
  std::vector<uint32_t> pageClusters;
  std::vector<uint32_t> dependencies;
  // Per DAG group: its level and LOD bounds as decoded (widened by the position slack, equal to the
  // CDAG decoder's), so requests can be computed from the table alone; and the page of its
  // member clusters.
  std::vector<uint32_t> groupLevel;
  std::vector<LodBounds> groupBounds;
  // Per DAG group: its member clusters, consecutive in its page's cluster list (a page lists its
  // groups' members group after group, in pageGroups order).
  std::vector<uint32_t> groupClusterCount;
  std::vector<uint32_t> groupPage;
  // Per DAG cluster: the page holding it (derived from pageClusters).
  std::vector<uint32_t> clusterPage;

  std::span<const uint32_t> groupsOf(uint32_t page) const {
    return {pageGroups.data() + pages[page].groupOffset, pages[page].groupCount};
  }
  std::span<const uint32_t> clustersOf(uint32_t page) const {
    return {pageClusters.data() + pages[page].clusterOffset, pages[page].clusterCount};
  }
  std::span<const uint32_t> dependenciesOf(uint32_t page) const {
    return {dependencies.data() + pages[page].dependencyOffset, pages[page].dependencyCount};
  }
  // The page holding the children of `group` (MIRAGE_PAGE_NONE for kNone).
  uint32_t childPage(uint32_t generatingGroup) const {
    return generatingGroup == kNone ? kNone : groupPage[generatingGroup];
  }
};

struct PagedDag {
  PageTable table;                         // as decodePageTable returns it
  std::vector<std::vector<uint8_t>> pages; // each page's standalone bytes, in table order
};

// Assigns groups to pages and encodes them. The DAG must pass checkDagStructure.
PagedDag buildPages(const ClusterDag& dag, const PageConfig& config = {});

std::vector<uint8_t> encodePageTable(const PageTable& table);
// Validates every count, range and id (each group in one page, each cluster in one page, a page's
// groups' members adding up to its clusters, root pages without groups, dependencies ascending and
// below their page); `file` names the source.
Result<PageTable> decodePageTable(std::span<const uint8_t> bytes, const std::string& file);

// One decoded page: enough to render its clusters without any other page.
struct PageData {
  uint32_t page = 0;
  std::vector<uint32_t> clusterIds; // DAG cluster ids (the table's clustersOf(page))
  // Offsets into the arrays below; level, groups and LOD bounds as the CDAG decoder gives them.
  std::vector<Cluster> clusters;
  std::vector<glm::vec3> positions;      // per page vertex
  std::vector<glm::vec3> normals;        // per page vertex, empty without normals
  std::vector<glm::vec2> uv0;            // per page vertex, empty without uvs
  std::vector<uint32_t> clusterVertices; // page-local vertex ids, per-cluster ranges
  std::vector<uint8_t> clusterIndices;   // local 8-bit indices, 3 per triangle
};

// Decodes page `page` of `table` with full validation: every count, range and id, and agreement
// with the table (page number, clusters and their member groups, group levels and bounds, sizes,
// grid). Errors name `file`
// and the page.
Result<PageData> decodePage(std::span<const uint8_t> bytes, const PageTable& table, uint32_t page,
                            const std::string& file);

// How a cut measures errors: projected to pixels from a camera (pixelScale > 0, shaderio/lod_error.h)
// or, with pixelScale 0, object-space errors compared with tau directly (selectCut's threshold).
struct CutView {
  glm::vec3 eye{0.0f}; // object space (mesh units)
  float znear = 0.01f;
  float pixelScale = 0.0f; // shaderio::projectionScale; 0: tau is an object-space error
  float tau = 0.0f;        // threshold: pixels, or mesh units when pixelScale is 0
};

float projectedError(const LodBounds& bounds, const CutView& view);
// LOCALCUT under `view` with everything resident (selectCut for camera views). Ascending ids.
std::vector<uint32_t> selectCut(const ClusterDag& dag, const CutView& view);

struct PageRequest {
  uint32_t page = 0;
  float priority = 0.0f; // shaderio::pageRequestPriority: projected error over tau (> 1)
};

// Resident pages: per page of the table, non-zero = resident. Closed: the root pages are resident
// and so is every dependency of a resident page.
bool residencyClosed(const PageTable& table, std::span<const uint8_t> resident);

struct ResidentCut {
  std::vector<uint32_t> clusters; // drawn (shaderio::residentCutDraws), ascending
  // Child pages the drawn clusters ask for (shaderio::residentCutRequests), one entry per page with
  // the largest priority, by priority (highest first), then page.
  std::vector<PageRequest> requests;
};

// The residency-aware cut over a closed resident set (what the GPU selection will compute). `dag`
// gives the clusters' group links; errors and spheres are the table's, as every page decodes them
// (equal to decodeDag's: with everything resident the cut is selectCut of the decoded DAG).
ResidentCut selectResidentCut(const ClusterDag& dag, const PageTable& table, std::span<const uint8_t> resident,
                              const CutView& view);

// Every page the full cut needs that is not resident: the pages holding a group whose projected
// error is above tau (the dependency closure of the pages holding the full cut's clusters), from
// the table alone. Priority: the largest projected error over tau of such a group in the page, raised
// to that of any page needing it, so the order (priority, then page) meets every dependency.
std::vector<PageRequest> wantedPages(const PageTable& table, std::span<const uint8_t> resident, const CutView& view);

} // namespace mirage::lod
