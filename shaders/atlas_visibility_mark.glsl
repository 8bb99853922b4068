// Body of the compute visibility's marking rasters (atlas_visibility_mark.comp, and
// atlas_visibility_mark_mask.comp with the alpha test of MASK clusters): the cluster renderer's
// compute raster (cluster_raster.glsl with MIRAGE_RASTER_MARK) walks the clusters again after the
// opaque raster, and every covered sample not behind the nearest depth that raster left in the
// 64-bit buffer, less MIRAGE_ATLAS_DEPTH_TOLERANCE of it, sets its patch's bit. BLEND samples in
// front count (every layer of glass); OPAQUE and MASK samples count where they are the nearest or
// tie with it within the tolerance: surfaces meeting or coplanar there, where the client's own
// rasterizer may round the other way and show this one. The tables come through
// ClusterPush::visibleInstanceAddress, which the raster kernels do not otherwise read.
#extension GL_EXT_shader_atomic_int64 : require
#extension GL_EXT_nonuniform_qualifier : require
#extension GL_EXT_control_flow_attributes : require
#define MIRAGE_RASTER_MARK 1
#include "cluster_common.glsl"
#include "mirage/shaderio/atlas_shading.h"

layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer AtlasTablesRef {
  AtlasVisibilityTables t;
};
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer AtlasUintRef { uint data[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer AtlasBitsRef { uint bits[]; };

uint atlasPatchOfId(AtlasVisibilityTables tables, uint id) {
  uint entry = (id >> MIRAGE_CLUSTER_TRIANGLE_BITS) - 1u, t = id & ((1u << MIRAGE_CLUSTER_TRIANGLE_BITS) - 1u);
  uint triangle = AtlasUintRef(tables.entryTriangleAddress).data[entry] + t;
  return AtlasUintRef(tables.patchOfTriangleAddress).data[triangle];
}

// Most samples find their patch's bit already set: a plain read first, the atomic only for the first.
void atlasSetPatchBit(AtlasVisibilityTables tables, uint patchId) {
  AtlasBitsRef bits = AtlasBitsRef(tables.patchBitsAddress);
  uint bit = 1u << (patchId & 31u);
  if ((bits.bits[patchId >> 5] & bit) == 0) atomicOr(bits.bits[patchId >> 5], bit);
}

void markSample(uint64_t nearest, float z, uint id) {
  if (z < uintBitsToFloat(uint(nearest >> 32)) * (1.0 - MIRAGE_ATLAS_DEPTH_TOLERANCE)) return; // behind it
  AtlasVisibilityTables tables = AtlasTablesRef(push.visibleInstanceAddress).t;
  atlasSetPatchBit(tables, atlasPatchOfId(tables, id));
}

#include "cluster_raster.glsl"
