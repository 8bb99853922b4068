#version 460
// Raster fallback (no 64-bit atomics): one indirect draw per instance (firstInstance = instance),
// six vertices per surfel forming a screen-aligned square around the disc the compute splat would
// write; the fragment shader cuts the disc and writes the same visibility id with depth testing.
#include "surfel_render_common.glsl"

layout(location = 0) flat out uint outId;
layout(location = 1) flat out vec3 outDisc; // centre and radius in pixels
layout(location = 2) flat out float outFade;
layout(location = 3) flat out vec3 outShape; // surfelEllipse, as the compute splat's discShape

void main() {
  uint slot = gl_InstanceIndex;
  uint i = uint(gl_VertexIndex) / 6u, corner = uint(gl_VertexIndex) % 6u;
  SurfelInstanceState s = SrStateRef(push.stateAddress).states[slot];
  SurfelRenderFrame f = SrFrameRef(push.frameAddress).frame;
  uint firstSurfel = SrCloudRef(push.cloudAddress).clouds[SrInstanceRef(push.instanceAddress).instances[slot].cloud].firstSurfel;
  vec3 quantized = surfelQuantized(SrUvec2Ref(push.positionAddress).v[firstSurfel + i]);
  vec4 clip = s.clipFromQuantized * vec4(quantized, 1.0);
  outId = s.firstId + i;
  outFade = s.fade;
  bool backFacing =
      s.eyeQuantized.w != 0.0 && surfelBackFacing(s, quantized, SrUvec2Ref(push.attributeAddress).v[firstSurfel + i].x);
  if (backFacing || clip.w <= 0.0 || clip.z > clip.w || clip.z < 0.0) {
    gl_Position = vec4(2.0, 2.0, 2.0, 1.0); // outside the clip volume: dropped
    outDisc = vec3(0.0);
    outShape = vec3(1.0, 0.0, 1.0);
    return;
  }
  float radius = min(s.radiusPixels / clip.w, MIRAGE_SURFEL_MAX_RADIUS_PX);
  // The square must hold the disc and the pixel holding the centre (up to one pixel away).
  float half_ = max(radius, 1.0);
  vec2 centre = (clip.xy / clip.w * 0.5 + 0.5) * f.camera.viewport;
  outDisc = vec3(centre, radius);
  outShape = vec3(1.0, 0.0, 1.0);
  if ((f.flags & MIRAGE_SURFEL_ORIENTED) != 0u && radius >= MIRAGE_SURFEL_ORIENTED_MIN_RADIUS_PX)
    outShape = surfelEllipse(s, quantized, clip, SrUvec2Ref(push.attributeAddress).v[firstSurfel + i].x, radius,
                             f.camera.viewport);
  // Corners of two triangles: (0,0) (1,0) (0,1), (1,0) (1,1) (0,1).
  const vec2 corners[6] = vec2[](vec2(-1, -1), vec2(1, -1), vec2(-1, 1), vec2(1, -1), vec2(1, 1), vec2(-1, 1));
  vec2 offsetNdc = corners[corner] * half_ * 2.0 / f.camera.viewport;
  gl_Position = vec4((clip.xy / clip.w + offsetNdc) * clip.w, clip.z, clip.w);
}
