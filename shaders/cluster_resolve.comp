#version 460
// Resolve, one compute thread per pixel: the visibility id names a visible cluster and triangle;
// the triangle is fetched, intersected with the pixel's ray (perspective-correct barycentrics, plus
// the rays one pixel right and down for texture and tangent-frame derivatives) and shaded with the
// shared material model (shading.glsl). Every backend feeds this same pass, so they give the same
// image. A compute pass rather than a full-screen fragment pass: on the H200, arithmetic measured
// far slower in fragment than in compute shaders (device notes), and this pass is all arithmetic
// and dependent loads. With occlusion culling it also records which clusters own pixels (the next
// frame's pass 1).
#extension GL_EXT_nonuniform_qualifier : require
#include "cluster_common.glsl"

layout(set = 0, binding = 0) uniform sampler2D textures[];
layout(set = 0, binding = 1) uniform usampler2D visImage;

#include "shading.glsl"
#include "cluster_surface.glsl"
#include "cluster_surfel_shade.glsl"

layout(set = 0, binding = 2, rgba16f) uniform writeonly image2D outImage;
layout(local_size_x = 8, local_size_y = 8) in;

// Pixel `target` of the colour target. Stereo: one dispatch over both eyes side by side; the right
// half shades with the right eye's frame (the next one in the frame buffer), px is the pixel
// within the eye.
void resolvePixel(ivec2 target) {
  // Only two scalars of the left eye's frame pick the eye: one whole frame is loaded per thread.
  uint64_t frameAddress = push.frameAddress;
  bool stereo = (FrameRef(frameAddress).frame.flags & MIRAGE_FRAME_STEREO) != 0;
  if (stereo && target.x >= int(FrameRef(frameAddress).frame.camera.viewport.x))
    frameAddress += MIRAGE_CLUSTER_FRAME_STRIDE;
  ClusterFrame f = FrameRef(frameAddress).frame;
  ivec2 px = target - ivec2(f.targetOffsetX, 0);
  if (px.x >= int(f.camera.viewport.x) || px.y >= int(f.camera.viewport.y)) return;
  uint v1, t, surfelId = 0;
  if ((f.flags & MIRAGE_FRAME_SOURCE_BUFFER) != 0) {
    uint pixel = uint(target.y) * targetRowPixels(f) + uint(target.x);
    uint64_t visSample = VisBufferRef(push.visBufferAddress).pixels[pixel];
    // The buffer's last reader this frame: covered pixels back to zero for the next frame's raster
    // (MIRAGE_FRAME_CLEAR_VIS; uncovered ones are zero already).
    if ((f.flags & MIRAGE_FRAME_CLEAR_VIS) != 0 && visSample != 0) VisBufferRef(push.visBufferAddress).pixels[pixel] = 0;
    uint id = uint(visSample & 0xffffffffUL);
    // Mixed scenes: a tagged id is a surfel, shaded where background pixels are.
    if (f.surfelLinkAddress != 0 && (id & MIRAGE_SURFEL_ID_TAG) != 0) {
      surfelId = id & ~MIRAGE_SURFEL_ID_TAG;
      id = 0;
    }
    v1 = id >> MIRAGE_CLUSTER_TRIANGLE_BITS;
    t = id & ((1u << MIRAGE_CLUSTER_TRIANGLE_BITS) - 1u);
  } else {
    uvec2 id = texelFetch(visImage, target, 0).xy;
    v1 = id.x;
    t = id.y;
  }
  // Background pixels (and surfels) leave before the dependent triangle fetches, so uncovered
  // screen costs one load and one store. Lavapipe still runs the loads below for the inactive
  // lanes of a SIMD group, so their ids stay valid: the visible list's entry 0 always holds a valid
  // pair (zeroed at creation).
  bool background = v1 == 0;
  if (background) {
    if (surfelId != 0) {
      ClusterSurfelLink link = LinkRef(f.surfelLinkAddress).link;
      imageStore(outImage, target, vec4(shadeLinkedSurfel(link, surfelId, f), 1.0));
      return;
    }
    imageStore(outImage, target, f.background);
    return;
  }
  if (background) t = 0;
  VisibleCluster vc = VisibleRef(push.visibleAddress).visible[background ? 0 : v1 - 1];
  GpuCluster c = ClusterRef(push.clusterAddress).clusters[vc.cluster];
  GpuClusterInstance inst = InstanceRef(push.instanceAddress).instances[vc.instance];
  ClusterTriangle tri = fetchTriangle(c, inst, t);
  ClusterSurface s = surfaceAt(f, tri, vec2(px) + 0.5);

  bool mirrored = (inst.flags & MIRAGE_INSTANCE_MIRRORED) != 0;
  bool front = (dot(cross(tri.e1, tri.e2), f.camera.eye.xyz - s.pos) > 0.0) != mirrored;
  if ((f.flags & MIRAGE_FRAME_FLAG_BACKFACES) != 0 && !front) {
    imageStore(outImage, target, vec4(1.0, 0.0, 1.0, 1.0)); // crack-test flag colour
    return;
  }
  vec3 normal = mat3(inst.normalMatrix) * (tri.a.normal * s.bary.x + tri.b.normal * s.bary.y + tri.c.normal * s.bary.z);
  GpuClusterMesh mesh = MeshRef(push.meshAddress).meshes[inst.mesh];
  GpuMaterial m = MaterialRef(push.materialAddress).materials[mesh.material];
  // Occlusion history for the next frame: exactly the clusters that own a pixel. A visible cluster
  // that owns none is only deferred to the next frame's pass 2, which tests it against the HZB.
  if ((f.flags & MIRAGE_FRAME_OCCLUSION) != 0 && setHistoryBitAt(inst.historyOffset + c.cluster - mesh.clusterOffset)) {
    atomicAdd(CounterRef(push.counterAddress).counters.historyKept, 1);
    setHistoryBitAt(f.instanceHistoryBase + vc.instance);
  }
  vec4 base = baseColor(m, s.uv, vec4(1.0), s.d); // DAG vertices carry no colours or tangents
  vec3 rgb = shadeSurfaceLights(m, base, s.pos, normal, vec4(0.0), front, s.uv, s.d, f.camera.eye.xyz, f.lightDir,
                                f.skyAmbient.rgb, f.groundAmbient.rgb, f.lightAddress, f.lightCount);
  imageStore(outImage, target, vec4(rgb, 1.0));
}

// Each workgroup resolves MIRAGE_RESOLVE_TILE_ROWS 8 x 8 tiles stacked vertically, one pixel of
// each per thread: more loads in flight per thread (H100: 2500 blobs 0.0375 -> 0.035 ms, stereo
// 2 x 2064 x 2208 0.143 -> 0.125).
void main() {
  for (uint k = 0; k < MIRAGE_RESOLVE_TILE_ROWS; ++k)
    resolvePixel(ivec2(gl_GlobalInvocationID.x,
                       (gl_WorkGroupID.y * MIRAGE_RESOLVE_TILE_ROWS + k) * 8 + gl_LocalInvocationID.y));
}
