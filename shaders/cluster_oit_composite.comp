#version 460
// Transparency composite, one thread per pixel, after the resolve and the blend raster: the
// pixel's linked list of blended fragments (cluster_raster_blend.comp) is gathered (oit_list.glsl,
// shared with the forward renderer's resolve), the nearest
// MIRAGE_OIT_MAX_LAYERS kept sorted by (depth, id), and each fragment, shaded with the forward
// material model (alpha = base-colour alpha), is blended back to front over the resolved opaque
// colour: c = mix(c, rgb, a), the forward renderer's SRC_ALPHA / ONE_MINUS_SRC_ALPHA. The order
// comes from the per-pixel sort, so the image does not depend on draw or list order. Particle
// billboards (render/particle_draw.h) append to the same lists with ids tagged
// MIRAGE_OIT_COLOR_ID_TAG: their colour, shaded where they were rasterized, is read from beside
// the pool, so particles and transparent surfaces sort together per pixel.
// Packed storage (MIRAGE_FRAME_OIT_PACKED, shaderio/oit.h): the pixel's range is read instead of
// its list, by wide independent loads into registers, and sorted there by a sorting network
// (oitSortedRange): the same keys in the same order; in fixed slots (ClusterFrame::oitFixedSlots)
// pixel p's slot i is at i * oitFixedStride + p (oitSortedSlots) unless the ranges pass placed its
// keys after all. Either way
// the sorted keys wait in shared memory (one column per thread) while the fragments are shaded in
// a loop, so the loop indexes no private array (local memory on NVIDIA) and keeps no 16 keys live
// in registers beside the shading. The rays of the pixel, the same for all its fragments, are
// found once.
// Specialization constant 0: MIRAGE_OIT_COMPOSITE_STORED for frames whose fragments all carry a
// stored colour (particles alone).
// push.visibleAddress is the blend list here (ids name its entries; the opaque list when the scene
// has no blend clusters: its entry 0 is valid for lanes that load without using it).
#extension GL_EXT_nonuniform_qualifier : require
#include "cluster_common.glsl"

layout(set = 0, binding = 0) uniform sampler2D textures[];

#include "shading.glsl"
#include "cluster_surface.glsl"

layout(constant_id = 0) const uint kComposite = 0u; // MIRAGE_OIT_COMPOSITE_STORED or 0
// Frames whose fragments all carry a stored colour (particles alone) take a variant without the
// shading code: fewer registers.
const bool kStoredOnly = (kComposite & MIRAGE_OIT_COMPOSITE_STORED) != 0u;

layout(set = 0, binding = 2, rgba16f) uniform image2D colorImage;
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer OitStoredColorRef { uvec2 colors[]; };
layout(local_size_x = 8, local_size_y = 8) in;

// The pixel's kept keys, far to near: [layer][thread].
shared uint64_t sortedKeys[OIT_SORT_KEYS][64];

// The colour and alpha of the fragment with list id `id` on the rays of its pixel: a particle's
// stored colour (tagged id: node + 1 | tag), or triangle (id & 127) of blend-list entry (id >> 7) - 1 shaded.
vec4 fragmentColor(ClusterFrame f, uint id, PixelRays rays) {
  bool stored = kStoredOnly || (id & MIRAGE_OIT_COLOR_ID_TAG) != 0u;
  // Indices valid on both sides (lavapipe loads for lanes of the untaken branch too).
  uint node = min(max(id & ~MIRAGE_OIT_COLOR_ID_TAG, 1u) - 1u, f.oitNodeCapacity - 1u); // id: node + 1 | tag
  uint v1 = stored ? 1u : max(id >> MIRAGE_CLUSTER_TRIANGLE_BITS, 1u);
  uint triangle = stored ? 0u : id & ((1u << MIRAGE_CLUSTER_TRIANGLE_BITS) - 1u);
  if (stored) {
    uvec2 packed = OitStoredColorRef(f.oitColorAddress).colors[node];
    return vec4(unpackHalf2x16(packed.x), unpackHalf2x16(packed.y));
  }
  return shadeClusterPixel(f, VisibleRef(push.visibleAddress).visible[v1 - 1], triangle, rays);
}

void main() {
  // Stereo: one dispatch over both eyes, as the resolve (the right half with the right eye's frame).
  ivec2 target = ivec2(gl_GlobalInvocationID.xy);
  uint64_t frameAddress = push.frameAddress;
  bool stereo = (FrameRef(frameAddress).frame.flags & MIRAGE_FRAME_STEREO) != 0;
  if (stereo && target.x >= int(FrameRef(frameAddress).frame.camera.viewport.x))
    frameAddress += MIRAGE_CLUSTER_FRAME_STRIDE;
  ClusterFrame f = FrameRef(frameAddress).frame;
  ivec2 px = target - ivec2(f.targetOffsetX, 0); // the pixel within the eye
  if (px.x >= int(f.camera.viewport.x) || px.y >= int(f.camera.viewport.y)) return;
  uint pixel = uint(target.y) * targetRowPixels(f) + uint(target.x);
  OitPixelHead head = OitHeadRef(f.oitHeadAddress).pixels[pixel];
  if (head.fragments == 0) return;
  vec3 color = imageLoad(colorImage, target).rgb;
  // The nearest MIRAGE_OIT_MAX_LAYERS keys (depth bits << 32 | id), far to near (oit_list.glsl).
  uint lane = gl_LocalInvocationIndex;
  OitPixel list;
  bool fixedSlots = false; // the pixel's keys in its fixed slots, counted by no earlier pass
  if ((f.flags & MIRAGE_FRAME_OIT_PACKED) != 0u) {
    // The range holds at most MIRAGE_OIT_MAX_LAYERS keys: its fragments, or its slots (NEAREST).
    // Fixed slots (unless the ranges were placed after all): every fragment, at most oitFixedSlots.
    fixedSlots = f.oitFixedSlots != 0u && (head.floorBits & MIRAGE_OIT_PACKED_READY) == 0u;
    uint slots = head.floorBits & MIRAGE_OIT_PACKED_COUNT;
    uint n = (head.floorBits & MIRAGE_OIT_PACKED_NEAREST) != 0u ? slots : min(slots, head.fragments);
    uint64_t keys[OIT_SORT_KEYS];
    uint kept = fixedSlots ? oitSortedSlots(f.oitNodeAddress, pixel, f.oitFixedStride,
                                            min(head.fragments, min(f.oitFixedSlots, OIT_SORT_KEYS)), keys)
                           : oitSortedRange(f.oitNodeAddress, head.head, min(n, OIT_SORT_KEYS), keys);
    list = OitPixel(int(kept), head.fragments, 0u);
    [[unroll]] for (int i = 0; i < OIT_SORT_KEYS; ++i)
      if (i < list.count) sortedKeys[i][lane] = keys[i];
  } else {
    list = oitGather(f.oitNodeAddress, f.oitNodeCapacity, head);
    [[unroll]] for (int i = 0; i < OIT_SORT_KEYS; ++i)
      if (i < list.count) sortedKeys[i][lane] = oitKeys[i];
  }
  oitCountPixel(f.oitCounterAddress, list, /*requests=*/fixedSlots);
  PixelRays rays = pixelRays(f, vec2(px) + 0.5);
  for (int i = 0; i < list.count; ++i)
    color = oitBlend(color, fragmentColor(f, uint(sortedKeys[i][lane] & 0xffffffffUL), rays));
  imageStore(colorImage, target, vec4(color, 1.0));
}
