#version 460
// The geometry-shader splatter's vertex stage: the points carry no data (surfel_splat.geom reads
// everything from gl_PrimitiveIDIn).
void main() {}
