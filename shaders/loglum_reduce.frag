#version 300 es
// Sums for Reinhard's log-average luminance over the virtual pixels only (thesis Alg. 5.5,
// fixed; [RSSF02] eq. 1): each output texel sums a BLOCK x BLOCK block of its input. The first
// pass (FIRST_PASS) reads the HDR target (rgb radiance) and the mask and sums
// (mask * log(L_w), mask); later passes sum those sums until one texel is left.
precision highp float;
precision highp sampler2D;

uniform sampler2D u_input;
uniform sampler2D u_mask;  // FIRST_PASS only
uniform ivec2 u_input_size;

out vec4 o_sum;

void main() {
  ivec2 base = ivec2(gl_FragCoord.xy) * BLOCK;
  vec2 sum = vec2(0.0);
  for (int dy = 0; dy < BLOCK; ++dy) {
    for (int dx = 0; dx < BLOCK; ++dx) {
      ivec2 p = base + ivec2(dx, dy);
      if (p.x >= u_input_size.x || p.y >= u_input_size.y) continue;
#ifdef FIRST_PASS
      if (texelFetch(u_mask, p, 0).r > 0.5) {
        float lum = dot(texelFetch(u_input, p, 0).rgb, vec3(0.299, 0.587, 0.114));
        sum += vec2(log(max(lum, 1e-6)), 1.0);  // floor: black pixels must not give -inf
      }
#else
      sum += texelFetch(u_input, p, 0).rg;
#endif
    }
  }
  o_sum = vec4(sum, 0.0, 1.0);
}
