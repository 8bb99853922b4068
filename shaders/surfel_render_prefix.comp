#version 460
// Per instance, every frame: frustum cull, then the prefix length k = P / r^2 (PADrend's formula;
// P = N_ref * d^2 scaled to world units, r = s * p / 2 with p the world size of a pixel at the
// reference depth, the nearest point of the instance's sphere), clamped to [1, N]. Writes the
// instance state the splat and resolve read, and the raster fallback's draw (6 vertices per surfel).
// The CPU mirror is surfelPrefix() in mirage/render/surfel_renderer.h (tested equal).
#include "surfel_render_common.glsl"

layout(local_size_x = MIRAGE_SURFEL_INSTANCE_WORKGROUP) in;

// Sphere against the frustum of the camera moved by `shift` (a translated frustum keeps its
// normals: plane w becomes w - dot(n, shift)).
bool sphereInFrustum(SurfelRenderFrame f, vec4 s, vec3 shift) {
  for (int i = 0; i < 5; ++i)
    if (dot(f.camera.planes[i].xyz, s.xyz - shift) + f.camera.planes[i].w < -s.w) return false;
  return true;
}

// In stereo the union of both eyes' frusta (the camera is the left eye's).
bool sphereVisible(SurfelRenderFrame f, vec4 s) {
  return sphereInFrustum(f, s, vec3(0.0)) || (f.eyes == 2u && sphereInFrustum(f, s, f.stereoEye.xyz));
}

// Reference depth: eye to the nearest point of the sphere; in stereo from the nearer eye, so the
// one selection draws the prefix that eye's mono frame would (the other eye's is at most that).
float referenceDepth(SurfelRenderFrame f, vec4 s) {
  float d = length(s.xyz - f.camera.eye.xyz);
  if (f.eyes == 2u) d = min(d, length(s.xyz - f.camera.eye.xyz - f.stereoEye.xyz));
  return max(d - s.w, f.camera.znear);
}

// Coherent order: a prefix length rounded up to the end of its block, so the drawn set is the
// blue-noise prefix of that length (Morton-sorted inside). C++ twin: coherentPrefix() in
// mirage/render/surfel_renderer.h (tested equal).
uint coherentPrefix(uint k, uint n, uint minBlock) {
  if (k == 0u) return 0u;
  uint i = k - 1u;
  uint size = minBlock;
  if (i > 0u) size = max(size, (1u << findMSB(i)) >> MIRAGE_SURFEL_COHERENT_BLOCK_SHIFT);
  uint start = i - i % size;
  return n - start <= size ? n : start + size;
}

void main() {
  SurfelRenderFrame f = SrFrameRef(push.frameAddress).frame;
  uint i = gl_GlobalInvocationID.x;
  if (i >= f.instanceCount) return;
  SurfelRenderInstance inst = SrInstanceRef(push.instanceAddress).instances[i];
  SurfelRenderCloud cloud = SrCloudRef(push.cloudAddress).clouds[inst.cloud];

  float distance = referenceDepth(f, inst.sphere);
  float P = cloud.boxMin.w * inst.maxScale * inst.maxScale; // world units squared
  float N = float(cloud.count);
  // k = P / r^2 with r = s * (distance / pixelScale) / 2; ceil so the spacing never exceeds r.
  float r = f.surfelSize * distance / (2.0 * f.camera.pixelScale);
  float k = P > 0.0 ? min(ceil(P / (r * r)), N) : N;
  k = max(k, min(N, 1.0));
  if ((f.flags & MIRAGE_SURFEL_ALL) != 0) k = N;
  // Cross-fade: below the distance where k reaches N the cloud is too sparse for s-pixel surfels, so
  // the mesh draws the instance; surfels fade in over the band above it.
  float fade = 1.0;
  if ((f.flags & MIRAGE_SURFEL_MESH_FADE) != 0 && P > 0.0 && N > 0.0) {
    float switchDistance = 2.0 * f.camera.pixelScale * sqrt(P / N) / f.surfelSize;
    fade = f.fadeBand > 0.0 ? clamp((distance - switchDistance) / (f.fadeBand * switchDistance), 0.0, 1.0)
                            : (distance >= switchDistance ? 1.0 : 0.0);
  }
  // Mixed scenes: the cluster renderer's instance of the same object draws the complementary pixels
  // (dither >= fade), and skips the instance entirely at fade 1 (cluster_cull.comp).
  if (push.meshFadeAddress != 0 && inst.meshInstance != ~0u) SrFadeRef(push.meshFadeAddress).v[inst.meshInstance] = fade;
  bool visible = ((f.flags & MIRAGE_SURFEL_FRUSTUM_CULL) == 0 || sphereVisible(f, inst.sphere)) && fade > 0.0;
  uint count = visible ? uint(k) : 0u;
  if (cloud.coherentMinBlock != 0u) count = coherentPrefix(count, cloud.count, cloud.coherentMinBlock);
  // Disc radius: the prefix's Poisson radius radii[k-1], which bounds its covering radius (every
  // sampled point lies within it of a prefix surfel), so discs of that radius leave no hole. In the
  // coherent order k is already rounded up: the drawn set is the blue-noise prefix of that length. Clouds
  // without radii (a PLY without them) fall back to the mean spacing sqrt(P / k).
  float radius = 0.0;
  if (count > 0u) {
    radius = SrFloatRef(push.radiusAddress).v[cloud.firstSurfel + count - 1u] * inst.maxScale;
    if (!(radius > 0.0)) radius = sqrt(P / float(count));
  }

  mat4 dequantize = mat4(vec4(cloud.boxStep.x, 0, 0, 0), vec4(0, cloud.boxStep.y, 0, 0), vec4(0, 0, cloud.boxStep.z, 0),
                         vec4(cloud.boxMin.xyz, 1.0));
  SurfelInstanceState s;
  s.clipFromQuantized = f.camera.viewProj * inst.model * dequantize;
  s.count = count;
  s.batchCount = (count + MIRAGE_SURFEL_BATCH - 1) / MIRAGE_SURFEL_BATCH;
  s.firstBatch = 0; // the scan pass fills these two
  s.firstId = 0;
  s.radiusPixels = radius * f.camera.pixelScale;
  s.fade = fade;
  s.distance = distance;
  s.firstSurfel = cloud.firstSurfel;
  // Back faces: only for single-sided materials (a leaf's surfels carry one normal but show both
  // sides), in the quantized frame the splat reads positions in.
  bool singleSided = SrMaterialRef(push.materialAddress).materials[cloud.material].doubleSided == 0u;
  mat4 objectFromWorld = inverse(inst.model);
  vec3 eyeObject = (objectFromWorld * vec4(f.camera.eye.xyz, 1.0)).xyz;
  s.eyeQuantized = vec4((eyeObject - cloud.boxMin.xyz) / cloud.boxStep.xyz,
                        (f.flags & MIRAGE_SURFEL_BACKFACE_CULL) != 0 && singleSided ? 1.0 : 0.0);
  // Subgroup merge (the merge pipeline reads it): everywhere, or where the cloud is dense on screen.
  bool merge = (f.flags & MIRAGE_SURFEL_MERGE_ALL) != 0 ||
               ((f.flags & MIRAGE_SURFEL_MERGE_AUTO) != 0 && s.radiusPixels < MIRAGE_SURFEL_MERGE_RADIUS_PX * distance);
  s.quantStep = vec4(cloud.boxStep.xyz, merge ? 1.0 : 0.0);
  s.stereoEyeQuantized = vec4((objectFromWorld * vec4(f.stereoEye.xyz, 0.0)).xyz / cloud.boxStep.xyz, 0.0);
  SrStateRef(push.stateAddress).states[i] = s;
  // vkCmdDrawIndirect: 6 vertices (two triangles) per surfel, firstInstance = instance index.
  SrDrawRef(push.drawAddress).draws[i] = uvec4(count * 6u, 1u, 0u, i);
  if (count > 0u) {
    atomicAdd(SrCounterRef(push.counterAddress).c.visibleInstances, 1u);
    if (fade < 1.0) atomicAdd(SrCounterRef(push.counterAddress).c.fadingInstances, 1u);
    if (merge) atomicAdd(SrCounterRef(push.counterAddress).c.mergedInstances, 1u);
  }
}
