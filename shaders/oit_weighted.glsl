// Weighted blended transparency's accumulation (McGuire and Bavoil 2013, equation 7), shared by
// every fragment shader that feeds the forward renderer's weighted targets: the weighted
// premultiplied colour and revealage (target 0), the weighted alpha (target 1 r). The weight falls
// with view distance z, so nearer layers dominate where the order matters.
// The weight's factor of view distance z (the weight is alpha times it).
float oitWeightedFactor(float z) { return clamp(10.0 / (1e-5 + pow(z / 5.0, 2.0) + pow(z / 200.0, 6.0)), 1e-2, 3e3); }

void oitWeighted(vec4 c, float z, out vec4 accum, out vec4 reveal) {
  float w = c.a * oitWeightedFactor(z);
  accum = vec4(c.rgb * (c.a * w), c.a);
  reveal = vec4(c.a * w, 0.0, 0.0, c.a);
}
