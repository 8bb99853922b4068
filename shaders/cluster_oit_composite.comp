#version 460
// Transparency composite, one thread per pixel, after the resolve and the blend raster: the
// pixel's linked list of blended fragments (cluster_raster_blend.comp) is gathered (oit_list.glsl,
// shared with the forward renderer's resolve), the nearest
// MIRAGE_OIT_MAX_LAYERS kept sorted by (depth, id), and each fragment, shaded with the forward
// material model (alpha = base-colour alpha), is blended back to front over the resolved opaque
// colour: c = mix(c, rgb, a), the forward renderer's SRC_ALPHA / ONE_MINUS_SRC_ALPHA. The order
// comes from the per-pixel sort, so the image does not depend on draw or list order.
// push.visibleAddress is the blend list here (ids name its entries).
#extension GL_EXT_nonuniform_qualifier : require
#include "cluster_common.glsl"

layout(set = 0, binding = 0) uniform sampler2D textures[];

#include "shading.glsl"
#include "cluster_surface.glsl"

layout(set = 0, binding = 2, rgba16f) uniform image2D colorImage;
layout(local_size_x = 8, local_size_y = 8) in;

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
  uint node = UintRef(f.oitHeadAddress).data[uint(target.y) * targetRowPixels(f) + uint(target.x)];
  if (node == 0) return;
  // The nearest MIRAGE_OIT_MAX_LAYERS keys (depth bits << 32 | id), far to near (oit_list.glsl).
  OitPixel list = oitGather(f.oitNodeAddress, f.oitNodeCapacity, node);
  oitCountPixel(f.oitCounterAddress, list);
  vec3 color = imageLoad(colorImage, target).rgb;
  for (int i = 0; i < list.count; ++i) {
    uint id = uint(oitKeys[i] & 0xffffffffUL);
    uint v1 = max(id >> MIRAGE_CLUSTER_TRIANGLE_BITS, 1u);
    VisibleCluster vc = VisibleRef(push.visibleAddress).visible[v1 - 1];
    vec4 c = shadeClusterPixel(f, vc, id & ((1u << MIRAGE_CLUSTER_TRIANGLE_BITS) - 1u), px);
    color = oitBlend(color, c);
  }
  imageStore(colorImage, target, vec4(color, 1.0));
}
