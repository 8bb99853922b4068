#version 460
#include "forward_common.glsl"

layout(set = 0, binding = 0) uniform sampler2D textures[];

layout(location = 0) in vec3 inWorldPos;
layout(location = 1) in vec3 inNormal;
layout(location = 2) in vec2 inUv;
layout(location = 3) in vec4 inTangent;
layout(location = 4) in vec4 inColor;

layout(location = 0) out vec4 outColor;

const float PI = 3.14159265359;

vec4 sampleOr(int index, vec2 uv, vec4 fallback) {
  return index >= 0 ? texture(textures[nonuniformEXT(index)], uv) : fallback;
}

// Tangent frame from screen-space derivatives when the mesh has no tangents (Schüler 2006).
mat3 derivativeFrame(vec3 n, vec3 p, vec2 uv) {
  vec3 dp1 = dFdx(p), dp2 = dFdy(p);
  vec2 duv1 = dFdx(uv), duv2 = dFdy(uv);
  vec3 dp2perp = cross(dp2, n), dp1perp = cross(n, dp1);
  vec3 t = dp2perp * duv1.x + dp1perp * duv2.x;
  vec3 b = dp2perp * duv1.y + dp1perp * duv2.y;
  float invmax = inversesqrt(max(max(dot(t, t), dot(b, b)), 1e-20));
  return mat3(t * invmax, b * invmax, n);
}

float distributionGGX(float nh, float a) {
  float a2 = a * a;
  float d = nh * nh * (a2 - 1.0) + 1.0;
  return a2 / (PI * d * d);
}

float visibilitySmithGGX(float nv, float nl, float a) {
  float k = a * 0.5; // Schlick-GGX, direct lighting
  return 0.25 / (max(nv * (1.0 - k) + k, 1e-4) * max(nl * (1.0 - k) + k, 1e-4));
}

void main() {
  FrameData frame = FrameRef(push.frameAddress).frame;
  GpuMaterial m = MaterialRef(push.materialAddress).materials[push.materialIndex];

  vec4 base = m.baseColorFactor * inColor * sampleOr(m.baseColorTexture, inUv, vec4(1.0));
  if (m.alphaMode == MIRAGE_ALPHA_MASK && base.a < m.alphaCutoff) discard;

  vec3 n = normalize(inNormal);
  if (!gl_FrontFacing) n = -n; // double-sided materials light their back faces
  if (m.normalTexture >= 0) {
    vec3 tn = texture(textures[nonuniformEXT(m.normalTexture)], inUv).xyz * 2.0 - 1.0;
    tn.xy *= m.normalScale;
    mat3 tbn;
    if (inTangent.w != 0.0) {
      vec3 t = normalize(inTangent.xyz - n * dot(n, inTangent.xyz));
      tbn = mat3(t, cross(n, t) * inTangent.w, n);
    } else {
      tbn = derivativeFrame(n, inWorldPos, inUv);
    }
    n = normalize(tbn * tn);
  }

  vec4 mr = sampleOr(m.metallicRoughnessTexture, inUv, vec4(1.0));
  float metallic = clamp(m.metallicFactor * mr.b, 0.0, 1.0);
  float roughness = clamp(m.roughnessFactor * mr.g, 0.04, 1.0);
  float occlusion = 1.0 + m.occlusionStrength * (sampleOr(m.occlusionTexture, inUv, vec4(1.0)).r - 1.0);
  vec3 emissive = m.emissiveFactor * sampleOr(m.emissiveTexture, inUv, vec4(1.0)).rgb;

  vec3 v = normalize(frame.eye.xyz - inWorldPos);
  vec3 l = frame.lightDir.xyz;
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
  vec3 direct = (diffuse + specular) * nl * frame.lightDir.w;

  // Hemisphere ambient: diffuse from sky/ground by the normal, a rough specular term from f0.
  vec3 ambientLight = mix(frame.groundAmbient.rgb, frame.skyAmbient.rgb, n.y * 0.5 + 0.5);
  vec3 ambient = ambientLight * (base.rgb * (1.0 - metallic) + f0 * (1.0 - roughness) * 0.5) * occlusion;

  float alpha = m.alphaMode == MIRAGE_ALPHA_BLEND ? base.a : 1.0;
  outColor = vec4(direct + ambient + emissive, alpha);
}
