// Mirage's one material and lighting model, shared by every renderer (forward.frag and the
// cluster-LOD resolve): glTF metallic-roughness, GGX, one directional light, hemisphere ambient.
// Derivatives are explicit because the visibility-buffer resolve reconstructs attributes per pixel
// instead of interpolating them; forward.frag passes dFdx/dFdy. Needs `textures[]` declared by the
// including shader.

const float PI = 3.14159265359;

struct SurfaceDerivatives {
  vec3 dpdx, dpdy;   // world position per pixel step
  vec2 duvdx, duvdy; // uv per pixel step
};

vec4 sampleGradOr(int index, vec2 uv, SurfaceDerivatives d, vec4 fallback) {
  return index >= 0 ? textureGrad(textures[nonuniformEXT(index)], uv, d.duvdx, d.duvdy) : fallback;
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

// Base colour and alpha: factor x texture x vertex colour (alpha MASK/BLEND read .a).
vec4 baseColor(GpuMaterial m, vec2 uv, vec4 vertexColor, SurfaceDerivatives d) {
  return m.baseColorFactor * vertexColor * sampleGradOr(m.baseColorTexture, uv, d, vec4(1.0));
}

// `tangent.w == 0`: no vertex tangents, the normal map uses a frame from derivatives.
vec3 shadeSurface(GpuMaterial m, vec4 base, vec3 worldPos, vec3 normal, vec4 tangent, bool frontFacing, vec2 uv,
                  SurfaceDerivatives d, vec3 eye, vec4 lightDir, vec3 skyAmbient, vec3 groundAmbient) {
  vec3 n = normalize(normal);
  if (!frontFacing) n = -n; // double-sided materials light their back faces
  if (m.normalTexture >= 0) {
    vec3 tn = textureGrad(textures[nonuniformEXT(m.normalTexture)], uv, d.duvdx, d.duvdy).xyz * 2.0 - 1.0;
    tn.xy *= m.normalScale;
    mat3 tbn;
    if (tangent.w != 0.0) {
      vec3 t = normalize(tangent.xyz - n * dot(n, tangent.xyz));
      tbn = mat3(t, cross(n, t) * tangent.w, n);
    } else {
      tbn = derivativeFrame(n, d);
    }
    n = normalize(tbn * tn);
  }
  vec4 mr = sampleGradOr(m.metallicRoughnessTexture, uv, d, vec4(1.0));
  float metallic = clamp(m.metallicFactor * mr.b, 0.0, 1.0);
  float roughness = clamp(m.roughnessFactor * mr.g, 0.04, 1.0);
  float occlusion = 1.0 + m.occlusionStrength * (sampleGradOr(m.occlusionTexture, uv, d, vec4(1.0)).r - 1.0);
  vec3 emissive = m.emissiveFactor * sampleGradOr(m.emissiveTexture, uv, d, vec4(1.0)).rgb;

  vec3 v = normalize(eye - worldPos);
  vec3 l = lightDir.xyz;
  vec3 h = normalize(v + l);
  float nl = max(dot(n, l), 0.0);
  float nv = max(abs(dot(n, v)), 1e-4);
  float nh = max(dot(n, h), 0.0);
  float vh = max(dot(v, h), 0.0);
  float a = roughness * roughness;

  vec3 f0 = mix(vec3(0.04), base.rgb, metallic);
  vec3 fresnel = f0 + (1.0 - f0) * pow(1.0 - vh, 5.0);
  vec3 diffuse = (1.0 - fresnel) * (1.0 - metallic) * base.rgb / PI;
  vec3 specular = fresnel * distributionGGX(nh, a) * visibilitySmithGGX(nv, nl, a);
  vec3 direct = (diffuse + specular) * nl * lightDir.w;
  vec3 ambientLight = mix(groundAmbient, skyAmbient, n.y * 0.5 + 0.5);
  vec3 ambient = ambientLight * (base.rgb * (1.0 - metallic) + f0 * (1.0 - roughness) * 0.5) * occlusion;
  return direct + ambient + emissive;
}
