#version 460
// Marking pass: a fragment that passed the depth test marks its triangle's patch visible. Early
// tests: nothing behind the prepass depth (opaque and MASK: EQUAL; BLEND: in front) runs at all.
#include "atlas_visibility_common.glsl"

layout(early_fragment_tests) in;

layout(location = 2) flat in uint inFirstTriangle;

void main() {
  uint triangle = inFirstTriangle + uint(gl_PrimitiveID);
  FlagRef(push.flagsAddress).flags[UintRef(push.patchOfTriangleAddress).values[triangle]] = 1u;
}
