// Structs shared by C++ and GLSL for the cluster-LOD renderer (written once, vk_lod_clusters'
// shaderio habit). GLSL reads them with scalar block layout through buffer device addresses, so the
// C++ sizes must match exactly: see the static_asserts. Data flow: docs/render.md.
#ifndef MIRAGE_SHADERIO_CLUSTER_H
#define MIRAGE_SHADERIO_CLUSTER_H

#include "mirage/shaderio/forward.h" // GpuMaterial, shared with the forward renderer
#include "mirage/shaderio/oit.h"     // OitNode, OitCounters, shared with the forward renderer

#ifdef __cplusplus
#include <cstddef>
namespace mirage::shaderio {
#endif

// Mesh-shader outputs and the triangle bits of a visibility id: a cluster has at most this many
// triangles and vertices (the DAG's default build is 128/128; larger clusters are refused at load).
#define MIRAGE_CLUSTER_MAX_TRIANGLES 128
#define MIRAGE_CLUSTER_MAX_VERTICES 256
// Triangle id bits in a packed 32-bit visibility id: ((visibleIndex + 1) << 7) | triangle.
#define MIRAGE_CLUSTER_TRIANGLE_BITS 7
// Workgroup size of the per-cluster passes (selection, occlusion): a multiple of both subgroup
// sizes we meet (lavapipe 8, NVIDIA 32).
#define MIRAGE_CLUSTER_WORKGROUP 64
#define MIRAGE_RESOLVE_TILE_ROWS 4 // cluster_resolve.comp: 8x8 pixel tiles per workgroup, stacked in y
// cluster_oit_composite.comp's specialization constant 0: every fragment of the frame has a stored
// colour (particles alone), so the variant carries no shading code.
#define MIRAGE_OIT_COMPOSITE_STORED 1u
// Mesh/compute-raster dispatches split the visible clusters over x and y: x stays under the
// guaranteed maxMeshWorkGroupCount / maxComputeWorkGroupCount of 65535.
#define MIRAGE_CLUSTER_DISPATCH_X 65535

// GpuClusterInstance::flags
#define MIRAGE_INSTANCE_DOUBLE_SIDED 1u // material draws back faces
#define MIRAGE_INSTANCE_MIRRORED 2u     // negative determinant: front faces are clockwise
#define MIRAGE_INSTANCE_ALPHA_MASK 4u   // material MASK: the visibility raster alpha-tests its pixels
#define MIRAGE_INSTANCE_ALPHA_BLEND 8u  // material BLEND: own list, drawn into the OIT lists after the resolve

// ClusterFrame::flags
#define MIRAGE_FRAME_FLAG_BACKFACES 1u   // debug: keep back faces and shade them in a flag colour
#define MIRAGE_FRAME_FRUSTUM_CULL 2u     // cull instances and clusters against the view frustum
#define MIRAGE_FRAME_SOURCE_BUFFER 4u    // resolve reads the 64-bit buffer (compute raster), else the image
#define MIRAGE_FRAME_HYBRID 8u           // selection splits clusters: small triangles to compute, large to hardware
#define MIRAGE_FRAME_OCCLUSION 16u       // two-pass HZB occlusion culling with last frame's visibility
#define MIRAGE_FRAME_CONE_CULL 32u       // per-cluster normal-cone back-face culling
#define MIRAGE_FRAME_HIERARCHY 64u       // selection traverses the LOD BVH (cluster_traverse.comp), else a flat pass
#define MIRAGE_FRAME_PVS 128u            // cull instances and clusters outside the camera cell's cluster PVS
#define MIRAGE_FRAME_BLEND_HYBRID 256u   // blend clusters split by hardwareCluster, as hybrid splits opaque ones
#define MIRAGE_FRAME_BLEND_HARDWARE 512u // every blend cluster to the hardware blend list
#define MIRAGE_FRAME_FOVEA 2048u         // tau grows with eccentricity from the gaze (ClusterFrame::fovea, lod_error.h)
#define MIRAGE_FRAME_DAG 1024u      // with HIERARCHY: traverse the DAG's group tree (GpuClusterMesh::dagNodeOffset)
#define MIRAGE_FRAME_OVERDRAW 4096u // debug: the rasters count covered samples per pixel (overdrawAddress)
// Stereo eye frames (docs/render.md, "Stereo"): the visibility target is both eyes side by side,
// rows of 2 * viewport.x pixels, this eye's half starting at targetOffsetX; the compute raster
// draws the right eye too from the left eye's frame (stereoClipDx).
#define MIRAGE_FRAME_STEREO 8192u
// The resolve zeroes the covered pixels of the 64-bit visibility buffer after reading them: nothing
// reads the buffer later in the frame (no blend raster, no debug view), so the next frame starts
// from a zero buffer without a fill pass (a full-target fill is 16 MB at 1080p, 73 MB in stereo at
// 2064 x 2208 per eye).
#define MIRAGE_FRAME_CLEAR_VIS 16384u
// Transparency in packed storage (shaderio/oit.h; --oit packed or fixed): the blend rasters run
// twice, counting then writing each pixel's fragments into its range (or once, into fixed slots:
// ClusterFrame::oitFixedSlots), oitNodeAddress names 64-bit keys.
#define MIRAGE_FRAME_OIT_PACKED 32768u
// GPU residency (ClusterFrame::pageSlotAddress): the selection draws resident clusters by the
// residency-aware cut (shaderio/lod_paging.h) and writes page feedback; the cull pass keeps the
// levels coarser than the cut (they are drawn where finer pages are missing).
#define MIRAGE_FRAME_RESIDENCY 65536u
// Lean compute raster (docs/render.md, "Lean raster"): the selection sends clusters whose every
// triangle provably takes the per-thread 32-bit walk (leanRasterCluster) to the down list, which
// the compute backend leaves unused, and a kernel with that walk alone draws them.
#define MIRAGE_FRAME_LEAN_RASTER 131072u

// Byte stride of consecutive ClusterFrames in the frame buffer (selection frame, left eye, right
// eye): shaders step from the left eye's frame to the right eye's by it.
#define MIRAGE_CLUSTER_FRAME_STRIDE 1024
// ClusterFrame::pvsInstanceAddress entry of an instance outside the cell's PVS.
#define MIRAGE_PVS_INSTANCE_CULLED 0xffffffffu

// LOD BVH (hierarchical selection): depth of the deepest node below its level root (0). The
// traversal runs one indirect dispatch per depth, so this bounds the passes per phase.
#define MIRAGE_LOD_MAX_DEPTH 24
// Children per inner BVH node.
#define MIRAGE_LOD_NODE_WIDTH 8

// Visible-cluster lists: the compute (or only) list grows up from entry 0, the hardware list of the
// hybrid backend (the lean list of the compute backend, MIRAGE_FRAME_LEAN_RASTER) grows down from
// the last entry, so one buffer and one id space serve both.
#define MIRAGE_LIST_UP 0u
#define MIRAGE_LIST_DOWN 1u
// push.rasterList of the blend rasters: ClusterCounters::lists[2][UP] holds the compute blend
// list's arguments (cluster_raster_blend.comp), lists[2][DOWN] the hardware one's (cluster_blend.*);
// both index ClusterFrame::blendVisibleAddress, the compute list from entry 0 up, the hardware
// list from entry blendCapacity - 1 down (shaders built with MIRAGE_BLEND_LISTS).
#define MIRAGE_RASTER_BLEND_LIST 4u
// cluster_args.comp's push.rasterList for the blend queue's dispatch (after the compute blend raster).
#define MIRAGE_BLEND_QUEUE_ARGS 3u
// Blend queue (docs/render.md, "Blend rasters"): the compute blend raster sends a triangle whose
// pixel box exceeds ClusterFrame::blendQueuePixels to one global queue instead of walking it with
// its cluster's workgroup; a second dispatch spreads the queued triangles' 8 x 8 pixel tiles over
// many workgroups (cluster_blend_queue.comp), each taking MIRAGE_BLEND_QUEUE_GROUP_TILES
// consecutive tiles, one thread per pixel.
#define MIRAGE_BLEND_QUEUE_TILE 8
#define MIRAGE_BLEND_QUEUE_GROUP_TILES 16 // at most 32: a thread keeps one bit per tile
// Tiles queued per frame stay below this (the 32-bit tile numbers and their sums cannot wrap);
// triangles beyond it, or beyond the queue's capacity, are walked by their cluster's workgroup.
#define MIRAGE_BLEND_QUEUE_MAX_TILES 0x7fffffffu
#define MIRAGE_BLEND_QUEUE_EYE 0x80000000u // BlendQueueTriangle::tiles: the right eye (stereo)
// Hierarchical depth levels kept (level 0 is full resolution): enough for 16384 pixels.
#define MIRAGE_HZB_MAX_LEVELS 15

// Normal cone of a cluster's triangles (meshopt_computeClusterBounds), for back-face culling: the
// whole cluster faces away from an eye e when dot(normalize(apex - e), axis) >= cutoff.
struct GpuClusterCone {
  vec4 axisCutoff; // xyz axis, w cutoff (1 or more: never culled)
  vec4 apex;       // xyz apex, w unused
};

// One cluster of some mesh's DAG (LOCALCUT needs self and parent bounds; culling needs `bounds`
// and the cone), everything the selection and the rasters read of it in one 128-byte record.
// Without residency the records are an array indexed by global cluster id. With residency
// (docs/render.md, "Residency") a record arrives with its page and lives in the page pool's units
// beside the page's geometry: the pool read as GpuCluster[] (a unit holds 192 whole records), the
// record of cluster i at the slot ClusterFrame::clusterSlotAddress names while its page is drawn.
// Either way VisibleCluster::cluster is the record's index, and `cluster` the global id.
struct GpuCluster {
  vec4 selfSphere;     // xyz centre, w radius of the generating group (object space)
  vec4 parentSphere;   // member group's sphere
  vec4 boundsSphere;   // the cluster's own triangles
  float selfError;     // object-space error of the generating group (0 at level 0)
  float parentError;   // member group's error; +inf for roots
  uint vertexOffset;   // first entry in clusterVertices (global attribute-vertex ids)
  uint triangleOffset; // first triangle in the global local-index byte array (3 bytes each)
  uint vertexCount;
  uint triangleCount;
  uint mesh;
  uint level;
  // Longest triangle edge in object space (the lean raster's bound on a triangle's screen extent);
  // +inf where unknown, which keeps the cluster on the general raster.
  float maxEdge;
  GpuClusterCone cone;
  uint cluster;   // global cluster id (history bits, debug colours: the record index is a slot with residency)
  uint page;      // residency: its page, numbered over every mesh (MIRAGE_PAGE_NONE without)
  uint childPage; // residency: the page of its generating group's members (MIRAGE_PAGE_NONE at level 0 or without)
};

// One attribute vertex (every DAG level reuses the input's vertices).
struct GpuClusterVertex {
  vec3 position;
  vec3 normal;
  vec2 uv;
};

struct GpuClusterMesh {
  vec4 sphere;        // object-space bounding sphere of the mesh
  uint clusterOffset; // first cluster in the global cluster table
  uint clusterCount;
  uint material;
  uint levelOffset; // first entry of this mesh's levels in the level table
  uint levelCount;
  // Largest |c - sphere.xyz| + r over the mesh's LOD spheres (self and parent): every sphere the
  // selection projects lies within this distance of the mesh centre, which bounds its distance to
  // the eye per instance.
  float reach;
  // First node of this mesh's LOD BVH (GpuLodNode): nodes [nodeOffset, nodeOffset + levelCount)
  // are the roots of the levels' BVHs, in level order; child offsets are relative to nodeOffset.
  uint nodeOffset;
  // First node of this mesh's group tree (--selection dag, the dissertation's DAG traversal): node 0
  // is the root; child offsets are relative to dagNodeOffset. Same GpuLodNode format.
  uint dagNodeOffset;
};

// One DAG level of a mesh: clusters are stored by level, so a level is a contiguous range. Its
// error extremes let the cull pass skip levels that cannot be on an instance's cut.
struct GpuClusterLevel {
  uint firstCluster; // mesh-local
  uint clusterCount;
  float minSelfError;   // smallest self error of the level's clusters
  float maxParentError; // largest parent error (+inf when a root is in the level)
};

// A visible instance and the range of its mesh's clusters the selection must test.
struct VisibleInstance {
  uint instance;
  uint firstCluster; // mesh-local
  uint clusterCount;
  uint levels; // the same range as levels: first level | level count << 16 (hierarchical selection)
};

// One node of a mesh's LOD BVH (vk_lod_clusters style): per DAG level a BVH over the level's
// member groups (the group a cluster is a child of; the level's roots form one more leaf), built at
// upload (cluster_lod_tree.cpp). A leaf lists its clusters, which share the group's parent sphere and
// error. The traversal (cluster_traverse.comp) enters a node only when
//   projected(sphere, maxParentError) > tau  (and, with frustum culling, the sphere is in view):
// the sphere encloses every parent sphere beneath, so it is nearer than any of them and the bound is
// >= every cluster's projected parent error; a node failing it has only clusters whose parent is
// already fine enough (LOCALCUT's `tau < parent` fails; with residency every draw and page request
// needs it too), so skipping it loses no cut cluster. The sphere also encloses the clusters' culling
// and self spheres (the frustum tests of a draw and of a page request), so the frustum test is
// conservative too; with residency those of a cluster join when its page arrives. Visited leaves
// are groups above the cut: the work follows the cut, not the mesh size.
struct GpuLodNode {
  vec4 sphere;          // object space, encloses the parent, self and culling spheres beneath
  float maxParentError; // largest parent error beneath (+inf with a root cluster beneath)
  uint childOffset;     // inner: first child node (mesh-relative); leaf: first entry in the leaf-cluster list
  uint childCount;      // inner: <= MIRAGE_LOD_NODE_WIDTH children (group tree: any); leaf: its clusters
  uint leaf;            // 1: childOffset/childCount are mesh-local cluster ids in the leaf-cluster list
};

// Work queues of the hierarchical selection: per phase and depth the indirect dispatch (x, 1, 1)
// over the queued nodes and their count. Zeroed every frame; pushing entry n adds a workgroup when
// n is a multiple of the workgroup size.
struct ClusterTraversal {
  uint args[2][MIRAGE_LOD_MAX_DEPTH][4]; // [phase][depth]: dispatch x, y, z, queued items
  uint nodesTested;
  uint queueOverflow; // items dropped past the queue capacity (clusters then missing: counted as overflow)
  uint pad0, pad1;
};

struct GpuClusterInstance {
  mat4 model;
  mat4 normalMatrix; // transpose(inverse(model)); its transpose brings the eye into object space
  vec4 sphere;       // world-space bounding sphere (per-instance culling)
  uint mesh;
  uint flags;         // MIRAGE_INSTANCE_*
  float maxScale;     // largest axis scale of `model`: object errors and radii become world ones
  uint historyOffset; // first bit of this instance's clusters in the visibility-history bitmask
};

// Appended by the selection pass, read by every rasterizer and by the resolve.
struct VisibleCluster {
  uint instance;
  uint cluster; // its record's index (GpuCluster): the global cluster id without residency, a pool slot with
};

// Per frame: camera, LOD threshold, culling planes, lighting (the forward renderer's FrameData
// fields plus what the cluster passes need).
struct ClusterFrame {
  ViewFrame camera; // camera.pixelScale turns object error / distance into pixels (lod_error.h)
  vec4 lightDir;    // xyz towards the light, w intensity
  vec4 skyAmbient;
  vec4 groundAmbient;
  float tau;            // LOD threshold in pixels
  uint flags;           // MIRAGE_FRAME_*
  uint visibleCapacity; // entries in the visible-cluster buffer
  uint instanceCount;
  vec4 background; // linear RGBA written where no cluster covers the pixel
  // Hybrid raster: clusters whose estimated triangle edge (2 * projected sphere radius /
  // sqrt(triangles)) is below this many pixels go to the compute rasterizer.
  float hybridThreshold;
  uint hzbLevels;                        // levels in the HZB (level 0: viewport size)
  uint64_t historyAddress;               // uint[] bitmask: (instance, cluster) owned a pixel last frame
  uint64_t candidateAddress;             // VisibleCluster[]: selected clusters left for the occlusion pass
  uint64_t hzbAddress;                   // float[]: every HZB level, farthest (smallest) reverse-Z depth per texel
  uint64_t lateInstanceAddress;          // VisibleInstance[]: visible instances that drew nothing last frame
  uint hzbOffset[MIRAGE_HZB_MAX_LEVELS]; // first float of each level
  uint instanceHistoryBase;              // history bit of instance i: instanceHistoryBase + i
  // Mixed scenes (docs/render.md, "Mixed scenes"); both 0 without surfels.
  uint64_t fadeAddress;       // float[] per instance: share of its pixels left to surfels (dither < fade)
  uint64_t surfelLinkAddress; // ClusterSurfelLink: the resolve shades ids tagged MIRAGE_SURFEL_ID_TAG
  // Hierarchical selection (MIRAGE_FRAME_HIERARCHY): the LOD BVH, its leaves' cluster lists, the
  // traversal counters and two ping-pong queues of uvec2(visible-instance row, mesh-relative node).
  uint64_t nodeAddress;        // GpuLodNode[]
  uint64_t leafClusterAddress; // uint[]: mesh-local cluster ids per leaf
  uint64_t traversalAddress;   // ClusterTraversal
  uint64_t queueAddress[2];    // uvec2[]: depth d reads queue d & 1, writes queue (d + 1) & 1
  uint queueCapacity;          // entries per queue
  uint targetOffsetX;          // stereo: the resolve writes pixel (x + targetOffsetX, y) of the colour target
  // Alpha BLEND (docs/render.md, "Alpha"): the blend clusters' own list, and the per-pixel linked
  // lists of their fragments (head per pixel: node index + 1, 0 = empty). 0 without blend materials.
  uint64_t blendVisibleAddress; // VisibleCluster[]
  uint64_t oitHeadAddress;      // OitPixelHead[] per pixel
  uint64_t oitNodeAddress;      // OitNode[], or (MIRAGE_FRAME_OIT_PACKED) uint64_t keys
  uint blendCapacity;           // entries of the blend list
  uint oitNodeCapacity;         // nodes (or keys) in the pool
  // Packed storage in fixed slots (--oit fixed; shaderio/oit.h, MIRAGE_OIT_FIXED_*): keys per pixel
  // of the first rasterization (0: counted ranges or lists), pixel p's slot i at
  // i * oitFixedStride + p, the stride the target's pixels (both eyes in stereo).
  uint oitFixedSlots;
  uint oitFixedStride;
  // Cluster PVS of the camera's view cell (MIRAGE_FRAME_PVS; lod/cluster_pvs.h): per instance the
  // first bit of its clusters in the bit array, or MIRAGE_PVS_INSTANCE_CULLED.
  uint64_t pvsInstanceAddress; // uint[] per instance
  uint64_t pvsClusterAddress;  // uint[]: bit (offset + mesh-local cluster) set = may be visible
  // Stereo selection (docs/render.md, "Stereo"): the eyes are camera.eye -/+ stereoHalf.xyz (half the
  // IPD along the camera's right vector; 0 in mono and in the per-eye raster frames). A sphere is
  // visible in either eye's frustum, facing is tested from both eyes, and LOD error is projected
  // from the nearest point of the segment between the eyes.
  vec4 stereoHalf;
  // Foveation (MIRAGE_FRAME_FOVEA; fovealTauScale in lod_error.h).
  vec4 fovea;       // xyz: gaze direction (world, unit), w: fovea radius in radians
  float foveaSlope; // tau factor growth per radian beyond the fovea (foveaSlope())
  // Debug views (docs/render.md, "Debug views"): MIRAGE_DEBUG_VIEW_* (shaderio/debug_view.h), and
  // with MIRAGE_FRAME_OVERDRAW the uint per pixel the rasters count every covered sample into,
  // before the depth test.
  uint debugView;
  uint64_t overdrawAddress;
  // Stereo, left eye frame: the right eye's clip x minus the left eye's for every world point (the
  // eyes share the projection and differ by a view-space x translation, so clip y, z, w agree).
  float stereoClipDx;
  // Point lights (docs/shading.md): read through their own buffer, not copied into the frame, so
  // the resolve loads only the count unless a scene has lights.
  uint lightCount;
  uint64_t lightAddress; // GpuPointLight[lightCount]
  // Alpha BLEND: ClusterCounters::oit (the OIT nodes' ids are visibility ids, shaderio/oit.h).
  uint64_t oitCounterAddress;
  // Blend queue of large blended triangles (MIRAGE_BLEND_QUEUE_*): BlendQueueTriangle[], 0 when
  // the frame has no queue (blend rasters other than compute, or no 64-bit buffer atomics).
  uint64_t blendQueueAddress;
  uint blendQueueCapacity; // entries usable this frame
  float blendQueuePixels;  // pixel boxes larger than this are queued
  // Particles (render/particle_draw.h): uvec2[oitNodeCapacity], the colour of each node whose id
  // carries MIRAGE_OIT_COLOR_ID_TAG. Without particles it names the node pool, as large, so a lane
  // that loads for an untaken branch (lavapipe) stays inside a buffer.
  uint64_t oitColorAddress;
  // GPU residency of paged DAGs (MIRAGE_FRAME_RESIDENCY; docs/render.md, "Residency"), 0 without:
  // per global cluster the pool slot of its record while its page is drawn, else MIRAGE_PAGE_NONE
  // (the only per-cluster table: page and child page are in the record); per page (numbered over
  // every mesh) its first pool unit while drawn, else MIRAGE_PAGE_NONE; per page the feedback the
  // selection writes, atomicMax of pageRequestPriority's float bits (shaderio/lod_paging.h).
  uint64_t clusterSlotAddress;
  uint64_t pageSlotAddress;
  uint64_t pageFeedbackAddress;
};

// One queued blended triangle (ClusterFrame::blendQueueAddress), as the compute blend raster would
// walk it: the snapped screen corners (pixels, on the 1/256 grid) with their depth, its id, and its
// pixel box's tiles numbered on from the tiles queued before it.
struct BlendQueueTriangle {
  vec3 a, b, c;   // x, y: screen position within the eye; z: depth (reverse-Z)
  uint id;        // visibility id: (blend-list entry + 1) << MIRAGE_CLUSTER_TRIANGLE_BITS | triangle
  uint tiles;     // 8 x 8 tiles of its sample box | MIRAGE_BLEND_QUEUE_EYE for the right eye
  uint firstTile; // sum of the tiles of the entries before it (ascending: a tile finds its entry by binary search)
};

// One raster pass's share of a list: entries [first, first + count) counted from the list's end
// (up: entry first + i; down: entry capacity - 1 - first - i), and its indirect arguments.
struct ClusterListArgs {
  uint dispatch[3]; // mesh tasks / compute raster: one workgroup per cluster, (x, y, 1)
  uint first;
  uint draw[4]; // vkCmdDrawIndirect: (3 * max triangles, count, 0, 0)
  uint count;
  uint pad0, pad1, pad2;
};

// GPU counters and indirect arguments, zeroed at the start of every frame and read back for --stats.
struct ClusterCounters {
  uint selectArgs[3];            // dispatch of the selection pass: (cluster groups, visible instances, 1)
  uint visibleInstances;         // rows of the selection passes: [0, earlyInstances) phase 1, the rest phase 2
  uint lateSelectArgs[3];        // phase-2 selection dispatch (over-estimate: every late instance)
  uint earlyInstances;           // selected in phase 1 (drew last frame, or occlusion off)
  uint instanceOcclusionArgs[3]; // late-instance HZB test dispatch
  uint lateInstances;            // visible instances that drew nothing last frame
  uint instancesOcclusionCulled; // late instances behind the HZB
  ClusterListArgs lists[3][2];   // [pass][MIRAGE_LIST_*]: what each raster pass draws; [2][UP]: the blend list
  uint occlusionArgs[3];         // pass-2 cull dispatch over the candidates
  uint candidates;               // selected clusters not drawn in pass 1 (tested against the HZB)
  uint allocated;                // list entries handed out (up + down), may exceed the capacity
  uint listEnd[2];               // entries appended so far per list (all passes)
  uint clustersTested;
  uint clustersSelected;  // on the cut and inside the frustum
  uint trianglesSelected; // triangles of the clusters drawn (both passes)
  uint clustersFrustumCulled;
  uint clustersOverflow;
  uint clustersHardware;        // hybrid: clusters sent to the hardware list
  uint trianglesNearClipped;    // compute raster: triangles clipped against the near plane
  uint clustersPass1;           // drawn in pass 1 (visible last frame)
  uint clustersOcclusionCulled; // pass 2: candidates behind the HZB
  uint clustersBackfaceCulled;  // normal cone entirely facing away
  uint historyKept;             // clusters owning a pixel (next frame's pass 1)
  uint blendClusters;           // appended to the blend list (may exceed its capacity: overflow)
  OitCounters oit;              // transparency lists: appends, composite drops, Mean Squared Layers
  uint instancesPvsCulled;      // in the frustum but outside the cell's PVS
  uint clustersPvsCulled;       // on the cut but outside the cell's cluster PVS
  // Entries of the two blend lists ([MIRAGE_LIST_UP]: compute, [DOWN]: hardware); their sum is
  // min(blendClusters, blendCapacity): blendClusters hands out the tickets, so the lists never meet.
  uint blendListEnd[2];
  // vkCmdDrawIndirect of the buffer backends' blend depth copy: (3, 1 if the hardware blend list is
  // non-empty else 0, 0, 0), so frames whose blend clusters all went to compute skip the copy.
  uint blendDepthDraw[4];
  // Blend queue: queued triangles << 32 | their tiles (one 64-bit word, so a triangle's slot and
  // first tile come from one compare-and-swap and ascend together), the queue dispatch
  // (cluster_args.comp pass MIRAGE_BLEND_QUEUE_ARGS), and large triangles that found the queue full
  // (walked by their cluster's workgroup instead).
  uint64_t blendQueueCounts;
  uint blendQueueArgs[3];
  uint blendQueueOverflow;
  uint selectDone; // flat selection without occlusion: workgroups done (the last writes pass 1's arguments)
};

// Push constants of every cluster pipeline: addresses of all the arrays (<= 128 bytes).
struct ClusterPush {
  uint64_t frameAddress;           // ClusterFrame
  uint64_t clusterAddress;         // GpuCluster[]
  uint64_t vertexAddress;          // GpuClusterVertex[]
  uint64_t clusterVertexAddress;   // uint[]: attribute-vertex ids per cluster
  uint64_t indexAddress;           // uint[]: local 8-bit indices packed 4 per word
  uint64_t meshAddress;            // GpuClusterMesh[]
  uint64_t instanceAddress;        // GpuClusterInstance[]
  uint64_t materialAddress;        // GpuMaterial[]
  uint64_t visibleInstanceAddress; // VisibleInstance[]
  uint64_t levelAddress;           // GpuClusterLevel[]
  uint64_t visibleAddress;         // VisibleCluster[]
  uint64_t counterAddress;         // ClusterCounters
  uint64_t visBufferAddress;       // uint64_t per pixel: depth << 32 | packed id (compute raster)
  uint maxMeshClusters;            // largest clusterCount over meshes (selection dispatch width)
  uint rasterList;                 // raster passes: pass * 2 + MIRAGE_LIST_*; HZB build: level
};

#ifdef __cplusplus
static_assert(sizeof(GpuCluster) == 128, "GpuCluster layout: 192 records fill a 24 KiB pool unit");
static_assert(sizeof(GpuClusterVertex) == 32, "GpuClusterVertex layout");
static_assert(sizeof(GpuClusterMesh) == 48, "GpuClusterMesh layout");
static_assert(sizeof(GpuClusterLevel) == 16, "GpuClusterLevel layout");
static_assert(sizeof(VisibleInstance) == 16, "VisibleInstance layout");
static_assert(sizeof(GpuClusterInstance) == 160, "GpuClusterInstance layout");
static_assert(sizeof(VisibleCluster) == 8, "VisibleCluster layout");
static_assert(sizeof(GpuClusterCone) == 32, "GpuClusterCone layout");
static_assert(sizeof(ClusterFrame) == 792, "ClusterFrame layout");
static_assert(sizeof(ClusterFrame) <= MIRAGE_CLUSTER_FRAME_STRIDE && MIRAGE_CLUSTER_FRAME_STRIDE % 256 == 0,
              "ClusterFrame stride");
static_assert(offsetof(ClusterFrame, pvsInstanceAddress) % 8 == 0, "ClusterFrame PVS address alignment");
static_assert(offsetof(ClusterFrame, nodeAddress) % 8 == 0, "ClusterFrame address alignment");
static_assert(offsetof(ClusterFrame, blendVisibleAddress) % 8 == 0, "ClusterFrame address alignment");
static_assert(offsetof(ClusterFrame, overdrawAddress) % 8 == 0, "ClusterFrame address alignment");
static_assert(offsetof(ClusterFrame, oitCounterAddress) % 8 == 0, "ClusterFrame address alignment");
static_assert(offsetof(ClusterFrame, blendQueueAddress) % 8 == 0, "ClusterFrame address alignment");
static_assert(offsetof(ClusterFrame, oitColorAddress) % 8 == 0, "ClusterFrame address alignment");
static_assert(offsetof(ClusterFrame, clusterSlotAddress) % 8 == 0, "ClusterFrame address alignment");
static_assert(sizeof(BlendQueueTriangle) == 48, "BlendQueueTriangle layout");
static_assert(sizeof(GpuLodNode) == 32, "GpuLodNode layout");
static_assert(sizeof(ClusterTraversal) == 2 * MIRAGE_LOD_MAX_DEPTH * 16 + 16, "ClusterTraversal layout");
static_assert(sizeof(ClusterListArgs) == 48, "ClusterListArgs layout");
static_assert(sizeof(ClusterCounters) == 16 + 36 + 6 * 48 + 140 + 28 + 4 /* tail padding */, "ClusterCounters layout");
static_assert(offsetof(ClusterCounters, blendQueueCounts) % 8 == 0, "64-bit atomic alignment");
static_assert(offsetof(ClusterCounters, blendQueueArgs) % 4 == 0, "indirect argument offsets");
static_assert(offsetof(ClusterCounters, lists) % 4 == 0 && offsetof(ClusterListArgs, draw) == 16,
              "indirect argument offsets");
static_assert(sizeof(ClusterPush) == 112, "ClusterPush layout");
} // namespace mirage::shaderio
#endif

#endif
