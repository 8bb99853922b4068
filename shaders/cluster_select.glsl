// Cluster selection shared by the flat pass (cluster_select.comp) and the LOD BVH traversal
// (cluster_traverse.comp): LOCALCUT (draw iff self error <= tau < parent error, both projected to
// pixels), frustum, normal-cone and (phase 2) HZB culling of one (instance, cluster), appended to
// the raster lists or the occlusion candidates.
#include "cluster_common.glsl"

#include "mirage/shaderio/lod_error.h"
#include "mirage/shaderio/lod_paging.h"

// A cluster's (or node's) object-space sphere and error projected to pixels for instance `inst`
// (projectedSphereError, shared with the CPU).
float projectedError(vec4 sphere, float error, GpuClusterInstance inst, ClusterFrame f) {
  vec3 c = (inst.model * vec4(sphere.xyz, 1.0)).xyz;
  return projectedSphereError(c, sphere.w, error, inst.maxScale, nearestEye(f, c), f.camera.znear, f.camera.pixelScale);
}

// The LOD threshold at a sphere: tau, grown with the sphere's eccentricity from the gaze under
// foveation (MIRAGE_FRAME_FOVEA; fovealTauScale, shared with the CPU).
float tauAt(vec4 sphere, GpuClusterInstance inst, ClusterFrame f) {
  if ((f.flags & MIRAGE_FRAME_FOVEA) == 0) return f.tau;
  vec3 c = (inst.model * vec4(sphere.xyz, 1.0)).xyz;
  return f.tau * fovealTauScale(c, sphere.w * inst.maxScale, f.camera.eye.xyz, f.fovea.xyz, f.fovea.w, f.foveaSlope);
}

// An object-space sphere of instance `inst` in world space.
vec4 instanceSphere(GpuClusterInstance inst, vec4 sphere) {
  return vec4((inst.model * vec4(sphere.xyz, 1.0)).xyz, sphere.w * inst.maxScale);
}

// Normal-cone test in object space (exact for any transform with a positive determinant: facing
// is affine-invariant there): the whole cluster faces away from the eye at world position `e`.
bool coneBackfacingFrom(GpuClusterInstance inst, GpuClusterCone cone, vec3 e) {
  vec3 eye = (transpose(inst.normalMatrix) * vec4(e, 1.0)).xyz; // inverse(model) * eye
  return dot(normalize(cone.apex.xyz - eye), cone.axisCutoff.xyz) >= cone.axisCutoff.w;
}

// Back-facing from the camera, in stereo from both eyes (ClusterFrame::stereoHalf).
bool coneBackfacing(GpuClusterInstance inst, GpuClusterCone cone, ClusterFrame f) {
  if (cone.axisCutoff.w >= 1.0) return false;
  vec3 h = f.stereoHalf.xyz;
  if (h == vec3(0.0)) return coneBackfacingFrom(inst, cone, f.camera.eye.xyz);
  return coneBackfacingFrom(inst, cone, f.camera.eye.xyz - h) && coneBackfacingFrom(inst, cone, f.camera.eye.xyz + h);
}

// Mesh-local cluster `meshLocal` of instance `instanceIndex` in selection phase `phase` (0: pass
// 1 and candidates, 1: late instances, HZB-tested here).
void selectCluster(uint instanceIndex, GpuClusterInstance inst, GpuClusterMesh mesh, uint meshLocal, uint phase) {
  CounterRef counters = CounterRef(push.counterAddress);
  atomicAdd(counters.counters.clustersTested, 1);
  ClusterFrame f = FrameRef(push.frameAddress).frame;
  // The record: by cluster id, or with residency at its slot in the pool, which also says whether
  // its page is drawn (clusters of pages not drawn are skipped: their records may be anywhere).
  uint record = mesh.clusterOffset + meshLocal;
  if ((f.flags & MIRAGE_FRAME_RESIDENCY) != 0) {
    record = UintRef(f.clusterSlotAddress).data[record];
    if (record == MIRAGE_PAGE_NONE) return;
  }
  GpuCluster c = ClusterRef(push.clusterAddress).clusters[record];
  float selfTau = tauAt(c.selfSphere, inst, f), parentTau = tauAt(c.parentSphere, inst, f);
  float selfError = projectedError(c.selfSphere, c.selfError, inst, f);
  float parentError = projectedError(c.parentSphere, c.parentError, inst, f);
  bool onCut = selfError <= selfTau && parentError > parentTau;
  if ((f.flags & MIRAGE_FRAME_RESIDENCY) != 0) {
    // Residency (docs/render.md, "Residency"): only clusters of drawn pages (above), by the
    // residency-aware cut; feedback for the pages of this view's frustum: the cluster's own page
    // when its member group is above the threshold (the cut uses it), its child page when it asks
    // for it.
    uvec2 pages = uvec2(c.page, c.childPage);
    UintRef slots = UintRef(f.pageSlotAddress);
    bool childrenResident = pages.y != MIRAGE_PAGE_NONE && slots.data[pages.y] != MIRAGE_PAGE_NONE;
    bool selfWithin = selfError <= selfTau, parentAbove = parentError > parentTau;
    bool frustum = (f.flags & MIRAGE_FRAME_FRUSTUM_CULL) == 0;
    UintRef feedback = UintRef(f.pageFeedbackAddress);
    if (parentAbove && (frustum || sphereVisible(instanceSphere(inst, c.parentSphere))))
      atomicMax(feedback.data[pages.x], floatBitsToUint(pageRequestPriority(parentError, parentTau)));
    if (pages.y != MIRAGE_PAGE_NONE && residentCutRequests(selfWithin, parentAbove, childrenResident) &&
        (frustum || sphereVisible(instanceSphere(inst, c.selfSphere))))
      atomicMax(feedback.data[pages.y], floatBitsToUint(pageRequestPriority(selfError, selfTau)));
    onCut = residentCutDraws(selfWithin, parentAbove, childrenResident);
  }
  if (!onCut) return;
  if (!pvsClusterVisible(f, instanceIndex, meshLocal)) { // hidden from every point of the camera's cell
    atomicAdd(counters.counters.clustersPvsCulled, 1);
    return;
  }
  vec4 s = vec4((inst.model * vec4(c.boundsSphere.xyz, 1.0)).xyz, c.boundsSphere.w * inst.maxScale);
  if ((f.flags & MIRAGE_FRAME_FRUSTUM_CULL) != 0 && !sphereVisible(s)) {
    atomicAdd(counters.counters.clustersFrustumCulled, 1);
    return;
  }
  atomicAdd(counters.counters.clustersSelected, 1);
  // Back-face cones: single-sided, non-mirrored instances only (mirrored ones swap which side is
  // kept; the crack-test mode keeps back faces).
  bool singleSided = (inst.flags & (MIRAGE_INSTANCE_DOUBLE_SIDED | MIRAGE_INSTANCE_MIRRORED)) == 0 &&
                     (f.flags & MIRAGE_FRAME_FLAG_BACKFACES) == 0;
  if ((f.flags & MIRAGE_FRAME_CONE_CULL) != 0 && singleSided && coneBackfacing(inst, c.cone, f)) {
    atomicAdd(counters.counters.clustersBackfaceCulled, 1);
    return;
  }
  VisibleCluster vc = VisibleCluster(instanceIndex, record);
  // Blended clusters never write the opaque visibility: their own list, drawn after the resolve.
  // They own no pixels, so with occlusion their instances are always late (phase 2, HZB-tested).
  if ((inst.flags & MIRAGE_INSTANCE_ALPHA_BLEND) != 0) {
    if (phase == 1 && !hzbVisible(s)) {
      atomicAdd(counters.counters.clustersOcclusionCulled, 1);
      return;
    }
    // A ticket first (the lists share the capacity), then the compute list from the front or the
    // hardware list from the back (hybrid: large triangles, as emitCluster splits opaque ones).
    if (atomicAdd(counters.counters.blendClusters, 1) < f.blendCapacity) {
      bool hardware = (f.flags & MIRAGE_FRAME_BLEND_HARDWARE) != 0 ||
                      ((f.flags & MIRAGE_FRAME_BLEND_HYBRID) != 0 && hardwareCluster(s, c.triangleCount, f));
      uint list = hardware ? MIRAGE_LIST_DOWN : MIRAGE_LIST_UP;
      uint slot = atomicAdd(counters.counters.blendListEnd[list], 1);
      VisibleRef(f.blendVisibleAddress).visible[hardware ? f.blendCapacity - 1u - slot : slot] = vc;
      atomicAdd(counters.counters.trianglesSelected, c.triangleCount);
    } else {
      atomicAdd(counters.counters.clustersOverflow, 1);
    }
    return;
  }
  // Phase 2 (instances that drew nothing last frame, past their own HZB test): each cluster is
  // tested against the HZB of pass 1 and drawn in pass 2.
  if (phase == 1) {
    if (!hzbVisible(s)) {
      atomicAdd(counters.counters.clustersOcclusionCulled, 1);
      return;
    }
    emitCluster(vc, s, c, inst, f);
    return;
  }
  // Two-pass occlusion: clusters drawn and unoccluded last frame are drawn now (pass 1); the rest
  // wait for the HZB built from pass 1 (cluster_occlusion.comp).
  if ((f.flags & MIRAGE_FRAME_OCCLUSION) != 0 && !historyBit(inst, meshLocal)) {
    uint slot = atomicAdd(counters.counters.candidates, 1);
    if (slot < f.visibleCapacity)
      VisibleRef(f.candidateAddress).visible[slot] = vc;
    else
      atomicAdd(counters.counters.clustersOverflow, 1); // dropped, like visible-list overflow
    return;
  }
  if (emitCluster(vc, s, c, inst, f) && (f.flags & MIRAGE_FRAME_OCCLUSION) != 0)
    atomicAdd(counters.counters.clustersPass1, 1);
}

