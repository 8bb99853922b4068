// The residency-aware LOD cut of a paged cluster DAG (docs/lod.md, "Paging"), written once for the
// GPU selection and the CPU reference (lod/paging.h): compiled as GLSL and as C++.
//
// A page holds whole groups' member clusters, so "the clusters a cluster replaces" (the children of
// its generating group) are resident or not together: one bit, the residency of the cluster's
// child page. With the resident pages closed under the page dependencies, a resident cluster is
// drawn iff its member group is above the threshold (roots: always) and either its own error is
// within it or its children are not resident: LOCALCUT with "group expanded" = "error above the
// threshold and children resident", which keeps every cut watertight and overlap-free.
#ifndef MIRAGE_SHADERIO_LOD_PAGING_H
#define MIRAGE_SHADERIO_LOD_PAGING_H

#ifdef __cplusplus
namespace mirage::shaderio {
#define MIRAGE_SHARED inline
#else
#define MIRAGE_SHARED
#endif

// Child page of a level-0 cluster (nothing to refine into).
#define MIRAGE_PAGE_NONE 0xffffffffu

// A resident cluster is drawn. selfWithinTau: its own (generating group's) projected error is at
// most the threshold; parentAboveTau: its member group's projected error is above it (true for
// roots, whose parent error is +inf); childrenResident: its child page is resident (false at level
// 0). With every page resident this is LOCALCUT.
MIRAGE_SHARED bool residentCutDraws(bool selfWithinTau, bool parentAboveTau, bool childrenResident) {
  return parentAboveTau && (selfWithinTau || !childrenResident);
}

// A resident cluster asks for its child page: it is drawn only because its children are missing.
// Every wanted page is either asked for by a drawn cluster or a dependency of one that is, so
// loading what is asked (with the dependencies first) reaches the full cut.
MIRAGE_SHARED bool residentCutRequests(bool selfWithinTau, bool parentAboveTau, bool childrenResident) {
  return parentAboveTau && !selfWithinTau && !childrenResident;
}

// Priority of a request: the asking cluster's projected self error over its threshold (> 1; +inf
// with the eye inside the sphere), so instances with different thresholds compare fairly. A page
// that several clusters ask for takes the largest; lod::wantedPages gives each dependency at
// least the priority of the pages that need it.
MIRAGE_SHARED float pageRequestPriority(float projectedSelfError, float tau) { return projectedSelfError / tau; }

#undef MIRAGE_SHARED
#ifdef __cplusplus
} // namespace mirage::shaderio
#endif

#endif
