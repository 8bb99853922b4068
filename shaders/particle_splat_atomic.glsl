// The particle splat by global atomics (particle_splat.glsl): one thread per record slot of every
// batch, each covered pixel's five sums added to the accumulators. Included after a sums file.
layout(local_size_x = MIRAGE_PARTICLE_DRAW_GROUP) in;

void main() {
  vec3 position;
  float size;
  vec4 c;
  if (splatClassify(splatRecordIndex(), /*list=*/true, /*shade=*/true, position, size, c) != SPLAT_SPLAT) return;
  for (uint e = 0; e < push.eyes; ++e) {
    SplatFootprint f;
    if (splatFootprint(e, position, size, f)) splatDirect(e, f, c, f.first, f.last);
  }
}
