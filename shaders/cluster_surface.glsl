// A visibility id's surface point at a pixel: the triangle is fetched and intersected with the
// pixel's ray (perspective-correct barycentrics), plus the rays one pixel right and down for
// texture and tangent-frame derivatives. Shared by the resolve, the alpha test of the visibility
// raster (cluster_alpha.glsl) and the transparency composite, so all three see the same uv and
// texture level. Needs cluster_common.glsl and shading.glsl (SurfaceDerivatives) first.

// Distance t and barycentrics (b1, b2) of the ray o + t*dir on the triangle's plane (Möller-Trumbore
// without the inside test: neighbouring pixels' rays may leave the triangle).
vec3 rayTriangle(vec3 o, vec3 dir, vec3 p0, vec3 e1, vec3 e2) {
  vec3 pv = cross(dir, e2);
  float inv = 1.0 / dot(e1, pv);
  vec3 tv = o - p0;
  vec3 qv = cross(tv, e1);
  return vec3(dot(e2, qv), dot(tv, pv), dot(dir, qv)) * inv; // (t, b1, b2)
}

vec3 pixelRay(ClusterFrame f, vec2 pixel) {
  vec2 ndc = pixel / f.camera.viewport * 2.0 - 1.0;
  vec4 q = f.camera.invViewProj * vec4(ndc, 0.5, 1.0);
  return q.xyz / q.w - f.camera.eye.xyz;
}

// Triangle t of cluster c in world space, with its attribute vertices.
struct ClusterTriangle {
  GpuClusterVertex a, b, c;
  vec3 p0, e1, e2;
};

ClusterTriangle fetchTriangle(GpuCluster c, GpuClusterInstance inst, uint t) {
  ClusterTriangle tri;
  tri.a = VertexRef(push.vertexAddress).vertices[triangleVertex(c, t, 0)];
  tri.b = VertexRef(push.vertexAddress).vertices[triangleVertex(c, t, 1)];
  tri.c = VertexRef(push.vertexAddress).vertices[triangleVertex(c, t, 2)];
  tri.p0 = (inst.model * vec4(tri.a.position, 1.0)).xyz;
  tri.e1 = (inst.model * vec4(tri.b.position, 1.0)).xyz - tri.p0;
  tri.e2 = (inst.model * vec4(tri.c.position, 1.0)).xyz - tri.p0;
  return tri;
}

struct ClusterSurface {
  vec3 bary;
  vec3 pos;
  vec2 uv;
  SurfaceDerivatives d;
};

// The rays from the eye through a pixel centre and through the centres one pixel right and down:
// what surfaceOnRays needs of the pixel, the same for every triangle under it.
struct PixelRays {
  vec3 centre, right, down;
};
PixelRays pixelRays(ClusterFrame f, vec2 centre) {
  return PixelRays(pixelRay(f, centre), pixelRay(f, centre + vec2(1, 0)), pixelRay(f, centre + vec2(0, 1)));
}

// The surface point of `tri` on a pixel's rays from the eye, with per-pixel derivatives.
ClusterSurface surfaceOnRays(vec3 eye, ClusterTriangle tri, PixelRays r) {
  vec3 h = rayTriangle(eye, r.centre, tri.p0, tri.e1, tri.e2);
  vec3 hx = rayTriangle(eye, r.right, tri.p0, tri.e1, tri.e2);
  vec3 hy = rayTriangle(eye, r.down, tri.p0, tri.e1, tri.e2);
  ClusterSurface s;
  s.bary = vec3(1.0 - h.y - h.z, h.y, h.z);
  s.pos = tri.p0 + tri.e1 * h.y + tri.e2 * h.z;
  s.uv = tri.a.uv * s.bary.x + tri.b.uv * s.bary.y + tri.c.uv * s.bary.z;
  s.d.dpdx = tri.e1 * (hx.y - h.y) + tri.e2 * (hx.z - h.z);
  s.d.dpdy = tri.e1 * (hy.y - h.y) + tri.e2 * (hy.z - h.z);
  s.d.duvdx = (tri.b.uv - tri.a.uv) * (hx.y - h.y) + (tri.c.uv - tri.a.uv) * (hx.z - h.z);
  s.d.duvdy = (tri.b.uv - tri.a.uv) * (hy.y - h.y) + (tri.c.uv - tri.a.uv) * (hy.z - h.z);
  return s;
}

// The surface point of `tri` under the pixel centre `centre`, with per-pixel derivatives.
ClusterSurface surfaceAt(ClusterFrame f, ClusterTriangle tri, vec2 centre) {
  return surfaceOnRays(f.camera.eye.xyz, tri, pixelRays(f, centre));
}

// Shaded colour (rgb) and coverage (a: 1, or base-colour alpha for BLEND) of triangle t of visible
// cluster vc on the rays of a pixel (pixelRays), as the forward renderer shades it (the
// transparency composite, which finds the rays once per pixel for all its fragments).
vec4 shadeClusterPixel(ClusterFrame f, VisibleCluster vc, uint t, PixelRays rays) {
  GpuCluster c = ClusterRef(push.clusterAddress).clusters[vc.cluster];
  GpuClusterInstance inst = InstanceRef(push.instanceAddress).instances[vc.instance];
  ClusterTriangle tri = fetchTriangle(c, inst, t);
  ClusterSurface s = surfaceOnRays(f.camera.eye.xyz, tri, rays);
  GpuMaterial m = MaterialRef(push.materialAddress).materials[MeshRef(push.meshAddress).meshes[inst.mesh].material];
  bool mirrored = (inst.flags & MIRAGE_INSTANCE_MIRRORED) != 0;
  bool front = (dot(cross(tri.e1, tri.e2), f.camera.eye.xyz - s.pos) > 0.0) != mirrored;
  vec3 normal = mat3(inst.normalMatrix) * (tri.a.normal * s.bary.x + tri.b.normal * s.bary.y + tri.c.normal * s.bary.z);
  vec4 base = baseColor(m, s.uv, vec4(1.0), s.d); // DAG vertices carry no colours or tangents
  vec3 rgb = shadeSurfaceLights(m, base, s.pos, normal, vec4(0.0), front, s.uv, s.d, f.camera.eye.xyz, f.lightDir,
                                f.skyAmbient.rgb, f.groundAmbient.rgb, f.lightAddress, f.lightCount);
  return vec4(rgb, m.alphaMode == MIRAGE_ALPHA_BLEND ? base.a : 1.0);
}
