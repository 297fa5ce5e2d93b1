#version 300 es
// Sums for colour matching (dissertation §5.6.2): the statistics of the virtual pixels in l alpha
// beta (eq. 11a), measured every frame. Each output texel sums a BLOCK x BLOCK block of its
// input. The first pass (FIRST_PASS) reads every STEP-th pixel of the HDR target (rgb radiance,
// times the exposure as the camera takes it; statistics need no more) and the mask, and writes (sum of lab, count) and (sum of lab^2, 0); later
// passes sum those until one texel is left.
precision highp float;
precision highp sampler2D;

uniform sampler2D u_input;   // FIRST_PASS: radiance; else the sums
uniform sampler2D u_input2;  // FIRST_PASS: the mask; else the sums of squares
uniform ivec2 u_input_size;
uniform float u_exposure_gain;  // FIRST_PASS
uniform mat3 u_lab_from_rgb;    // FIRST_PASS

layout(location = 0) out vec4 o_sum;
layout(location = 1) out vec4 o_sum2;

void main() {
#ifdef FIRST_PASS
  const int step = STEP;
#else
  const int step = 1;
#endif
  ivec2 base = ivec2(gl_FragCoord.xy) * BLOCK * step;
  vec4 sum = vec4(0.0), sum2 = vec4(0.0);
  for (int dy = 0; dy < BLOCK; ++dy) {
    for (int dx = 0; dx < BLOCK; ++dx) {
      ivec2 p = base + ivec2(dx, dy) * step;
      if (p.x >= u_input_size.x || p.y >= u_input_size.y) continue;
#ifdef FIRST_PASS
      if (texelFetch(u_input2, p, 0).r > 0.5) {
        vec3 lab = u_lab_from_rgb * (max(texelFetch(u_input, p, 0).rgb, 0.0) * u_exposure_gain);
        sum += vec4(lab, 1.0);
        sum2 += vec4(lab * lab, 0.0);
      }
#else
      sum += texelFetch(u_input, p, 0);
      sum2 += texelFetch(u_input2, p, 0);
#endif
    }
  }
  o_sum = sum;
  o_sum2 = sum2;
}
