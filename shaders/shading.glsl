// Mirage's one material and lighting model, shared by every renderer (forward.frag, the cluster-LOD
// resolve and the surfel resolve): glTF metallic-roughness (GGX) or Blinn-Phong, per-map UV
// transforms, detail maps, one directional light, point lights, hemisphere ambient. The
// formulas are written down in docs/shading.md. Derivatives are explicit because the
// visibility-buffer resolve reconstructs attributes per pixel instead of interpolating them;
// forward.frag passes dFdx/dFdy. Needs `textures[]` declared by the including shader, and buffer
// references, scalar layout and 64-bit integers enabled (every includer reads materials so).

const float PI = 3.14159265359;

// The maps a pipeline may meet, bit MIRAGE_MAP_k per map (the seed's specialization constants): a
// map whose bit is 0 is never sampled and its branches compile away. The default, every bit, leaves
// each map to the material's texture index (one pipeline for every material); renderers specialize
// it to their scene's maps under MIRAGE_SPECIALIZE_MAPS=1 (docs/shading.md, "Optional maps").
layout(constant_id = MIRAGE_SPEC_MATERIAL_MAPS) const uint kMaterialMaps = 0xffffffffu;

// Whether texture `index` of map `map` is there: the pipeline may meet the map and the material has it.
bool hasMap(int index, int map) { return (kMaterialMaps & (1u << uint(map))) != 0u && index >= 0; }

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer PointLightRef { GpuPointLight lights[]; };

struct SurfaceDerivatives {
  vec3 dpdx, dpdy;   // world position per pixel step
  vec2 duvdx, duvdy; // uv per pixel step
};

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer MapTransformRef {
  GpuMapTransform maps[];
};

// The material's UV transform of `map` (MIRAGE_MAP_*) applied to uv and to its derivatives.
vec2 mapUv(GpuMaterial m, int map, vec2 uv) {
  GpuMapTransform t = MapTransformRef(m.mapTransformAddress).maps[map];
  vec3 p = vec3(uv, 1.0);
  return vec2(dot(t.row0, p), dot(t.row1, p));
}
SurfaceDerivatives mapDerivatives(GpuMaterial m, int map, SurfaceDerivatives d) {
  GpuMapTransform t = MapTransformRef(m.mapTransformAddress).maps[map];
  mat2 a = mat2(t.row0.x, t.row1.x, t.row0.y, t.row1.y); // linear part, by columns
  d.duvdx = a * d.duvdx;
  d.duvdy = a * d.duvdy;
  return d;
}

// Texture `index` of map `map` through the map's UV transform; `fallback` without a texture.
vec4 sampleMap(GpuMaterial m, int index, int map, vec2 uv, SurfaceDerivatives d, vec4 fallback) {
  if (!hasMap(index, map)) return fallback;
  SurfaceDerivatives t = mapDerivatives(m, map, d);
  return textureGrad(textures[nonuniformEXT(index)], mapUv(m, map, uv), t.duvdx, t.duvdy);
}

// The detail mask (per-pixel mix factor of the detail maps): its R, 1 without a mask texture, 0
// without detail maps.
float detailMask(GpuMaterial m, vec2 uv, SurfaceDerivatives d) {
  if (!hasMap(m.detailAlbedoTexture, MIRAGE_MAP_DETAIL_ALBEDO) && !hasMap(m.detailNormalTexture, MIRAGE_MAP_DETAIL_NORMAL))
    return 0.0;
  return sampleMap(m, m.detailMaskTexture, MIRAGE_MAP_DETAIL_MASK, uv, d, vec4(1.0)).r;
}

// Tangent frame from derivatives when the mesh has no tangents (Schüler 2006), as forward.frag.
mat3 derivativeFrame(vec3 n, SurfaceDerivatives d) {
  vec3 dp2perp = cross(d.dpdy, n), dp1perp = cross(n, d.dpdx);
  vec3 t = dp2perp * d.duvdx.x + dp1perp * d.duvdy.x;
  vec3 b = dp2perp * d.duvdx.y + dp1perp * d.duvdy.y;
  float invmax = inversesqrt(max(max(dot(t, t), dot(b, b)), 1e-20));
  return mat3(t * invmax, b * invmax, n);
}

float distributionGGX(float nh, float a) {
  float a2 = a * a;
  float dd = nh * nh * (a2 - 1.0) + 1.0;
  return a2 / (PI * dd * dd);
}

float visibilitySmithGGX(float nv, float nl, float a) {
  float k = a * 0.5; // Schlick-GGX, direct lighting
  return 0.25 / (max(nv * (1.0 - k) + k, 1e-4) * max(nl * (1.0 - k) + k, 1e-4));
}

// Base colour and alpha: factor x texture x vertex colour (alpha MASK/BLEND read .a), times the
// detail albedo x 2 mixed in by the detail mask (a detail texel of 0.5 changes nothing).
vec4 baseColor(GpuMaterial m, vec2 uv, vec4 vertexColor, SurfaceDerivatives d) {
  vec4 base = m.baseColorFactor * vertexColor * sampleMap(m, m.baseColorTexture, MIRAGE_MAP_BASE_COLOR, uv, d, vec4(1.0));
  if (hasMap(m.detailAlbedoTexture, MIRAGE_MAP_DETAIL_ALBEDO)) {
    vec3 detail = sampleMap(m, m.detailAlbedoTexture, MIRAGE_MAP_DETAIL_ALBEDO, uv, d, vec4(0.5)).rgb * 2.0;
    base.rgb *= mix(vec3(1.0), detail, detailMask(m, uv, d));
  }
  return base;
}

// Blinn-Phong specular exponent from glossiness 0..1: 2 .. 2048.
float blinnPhongExponent(float glossiness) { return exp2(1.0 + 10.0 * glossiness); }

// Windowed inverse-square falloff of a point light at distance `dist` (Karis 2013): 1 / (d^2 + 1),
// faded to exactly 0 at the radius.
float pointLightFalloff(float dist, float radius) {
  float x = dist / radius;
  float window = clamp(1.0 - x * x * x * x, 0.0, 1.0);
  return window * window / (dist * dist + 1.0);
}

// What each light's term needs, evaluated once per pixel.
struct SurfacePoint {
  vec3 n, v;
  vec3 base; // albedo, linear
  float metallic, roughness;
  vec3 f0;
  uint model;
  vec3 specularColor;
  float exponent;
};

// Outgoing radiance towards v per unit irradiance from direction l (BRDF x cos).
vec3 lightTerm(SurfacePoint s, vec3 l) {
  float nl = max(dot(s.n, l), 0.0);
  vec3 h = normalize(s.v + l);
  float nh = max(dot(s.n, h), 0.0);
  if (s.model == MIRAGE_MODEL_BLINN_PHONG) {
    // Normalized Blinn-Phong: (s + 8) / (8 pi) keeps the reflected energy constant over exponents.
    vec3 specular = s.specularColor * (s.exponent + 8.0) / (8.0 * PI) * pow(nh, s.exponent);
    return (s.base / PI + specular) * nl;
  }
  float nv = max(abs(dot(s.n, s.v)), 1e-4);
  float vh = max(dot(s.v, h), 0.0);
  float a = s.roughness * s.roughness;
  vec3 fresnel = s.f0 + (1.0 - s.f0) * pow(1.0 - vh, 5.0);
  vec3 diffuse = (1.0 - fresnel) * (1.0 - s.metallic) * s.base / PI;
  vec3 specular = fresnel * distributionGGX(nh, a) * visibilitySmithGGX(nv, nl, a);
  return (diffuse + specular) * nl;
}

// Tangent-space normal map sample (xyz in -1..1) of map `map`, or (0, 0, 1) without a texture.
vec3 tangentNormal(GpuMaterial m, int index, int map, vec2 uv, SurfaceDerivatives d) {
  if (!hasMap(index, map)) return vec3(0.0, 0.0, 1.0);
  return sampleMap(m, index, map, uv, d, vec4(0.5, 0.5, 1.0, 1.0)).xyz * 2.0 - 1.0;
}

// `tangent.w == 0`: no vertex tangents, the normal map uses a frame from derivatives. Point lights:
// `lightCount` GpuPointLights at `lightAddress` (0 lights: the address is not read).
vec3 shadeSurfaceLights(GpuMaterial m, vec4 base, vec3 worldPos, vec3 normal, vec4 tangent, bool frontFacing, vec2 uv,
                        SurfaceDerivatives d, vec3 eye, vec4 lightDir, vec3 skyAmbient, vec3 groundAmbient,
                        uint64_t lightAddress, uint lightCount) {
  vec3 n = normalize(normal);
  if (!frontFacing) n = -n; // double-sided materials light their back faces
  bool normalMap = hasMap(m.normalTexture, MIRAGE_MAP_NORMAL);
  bool detailNormal = hasMap(m.detailNormalTexture, MIRAGE_MAP_DETAIL_NORMAL);
  if (normalMap || detailNormal) {
    vec3 tn = tangentNormal(m, m.normalTexture, MIRAGE_MAP_NORMAL, uv, d);
    tn.xy *= m.normalScale;
    if (detailNormal) { // detail normal added by the mask (UDN blend)
      vec3 dn = tangentNormal(m, m.detailNormalTexture, MIRAGE_MAP_DETAIL_NORMAL, uv, d);
      tn.xy += dn.xy * detailMask(m, uv, d);
    }
    mat3 tbn;
    if (tangent.w != 0.0) {
      vec3 t = normalize(tangent.xyz - n * dot(n, tangent.xyz));
      tbn = mat3(t, cross(n, t) * tangent.w, n);
    } else {
      tbn = derivativeFrame(n, mapDerivatives(m, normalMap ? MIRAGE_MAP_NORMAL : MIRAGE_MAP_DETAIL_NORMAL, d));
    }
    n = normalize(tbn * tn);
  }
  vec4 mr = sampleMap(m, m.metallicRoughnessTexture, MIRAGE_MAP_METALLIC_ROUGHNESS, uv, d, vec4(1.0));
  float occlusion =
      1.0 + m.occlusionStrength * (sampleMap(m, m.occlusionTexture, MIRAGE_MAP_OCCLUSION, uv, d, vec4(1.0)).r - 1.0);
  vec3 emissive = m.emissiveFactor * sampleMap(m, m.emissiveTexture, MIRAGE_MAP_EMISSIVE, uv, d, vec4(1.0)).rgb;

  SurfacePoint s;
  s.n = n;
  s.v = normalize(eye - worldPos);
  s.base = base.rgb;
  s.model = m.shadingModel;
  s.metallic = s.model == MIRAGE_MODEL_BLINN_PHONG ? 0.0 : clamp(m.metallicFactor * mr.b, 0.0, 1.0);
  s.roughness = clamp(m.roughnessFactor * mr.g, 0.04, 1.0);
  s.f0 = mix(vec3(0.04), base.rgb, s.metallic);
  s.specularColor = m.specularColor;
  s.exponent = blinnPhongExponent(m.glossiness);

  vec3 direct = lightTerm(s, lightDir.xyz) * lightDir.w;
  for (uint i = 0; i < lightCount; ++i) {
    GpuPointLight pl = PointLightRef(lightAddress).lights[i];
    vec3 toLight = pl.position - worldPos;
    float dist = length(toLight);
    if (dist >= pl.radius || dist <= 0.0) continue;
    direct += lightTerm(s, toLight / dist) * pl.color * pointLightFalloff(dist, pl.radius);
  }
  vec3 ambientLight = mix(groundAmbient, skyAmbient, n.y * 0.5 + 0.5);
  vec3 ambientSpecular = s.model == MIRAGE_MODEL_BLINN_PHONG ? s.specularColor * m.glossiness * 0.5
                                                             : s.f0 * (1.0 - s.roughness) * 0.5;
  vec3 ambient = ambientLight * (base.rgb * (1.0 - s.metallic) + ambientSpecular) * occlusion;
  return direct + ambient + emissive;
}
