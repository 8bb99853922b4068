// Shared by the point-cloud capture passes: where the orthographic ray through a texel centre of
// view w meets a point's disc plane. The splat and the resolve call the same function, so the
// resolve's position is the one whose depth won.

// Texel centre (x + 0.5, y + 0.5) of `view` on the plane through the capture centre, and the
// view's unit axes: clip.x = dot(p - c, right) / R, clip.y = -dot(p - c, up) / R (surfel capture's
// makeView), pixel = (clip * 0.5 + 0.5) * resolution.
struct PointView {
  vec3 right, up, towardsCamera;
};

PointView pointView(SurfelView v) {
  PointView pv;
  pv.right = normalize(vec3(v.viewProj[0][0], v.viewProj[1][0], v.viewProj[2][0]));
  pv.up = -normalize(vec3(v.viewProj[0][1], v.viewProj[1][1], v.viewProj[2][1]));
  pv.towardsCamera = v.direction.xyz;
  return pv;
}

vec3 texelOrigin(PointView pv, vec4 center, uint resolution, uint x, uint y) {
  vec2 clip = (vec2(x, y) + 0.5) / float(resolution) * 2.0 - 1.0;
  return center.xyz + pv.right * (clip.x * center.w) - pv.up * (clip.y * center.w);
}

// The ray's point on the disc plane (false when the disc is edge-on).
bool discPlanePoint(PointView pv, vec3 origin, SurfelPoint p, out vec3 q) {
  float facing = dot(pv.towardsCamera, p.normal);
  if (abs(facing) < 1e-3) return false; // edge-on: the neighbours' discs cover this texel
  q = origin + pv.towardsCamera * (dot(p.position - origin, p.normal) / facing);
  return true;
}

// Distance from the view's camera plane (the sphere's near side): >= 0 inside the sphere.
float pointDepth(PointView pv, vec4 center, vec3 q) { return max(center.w - dot(q - center.xyz, pv.towardsCamera), 0.0); }
