#version 300 es
// Tone maps the virtual pixels over the camera frame. The renderer uploads the frame into the
// output first and runs this pass with a depth test that passes only where geometry was drawn,
// so pixels outside the mask are the camera frame's bytes exactly and cost nothing. TONE_MODE (defined by the renderer, one
// program per mode so that no pixel pays for another mode's code): 0 camera-matched,
// 1 Reinhard, 2 linear.
precision highp float;
precision highp sampler2D;

uniform sampler2D u_hdr;       // rgb radiance, a = mask
uniform sampler2D u_response;  // encode(x) per channel at x = (i / (n-1))^2
uniform sampler2D u_log_sum;   // 1x1: (sum of log L_w, count) over the mask
uniform float u_exposure_gain;
uniform float u_key;
uniform float u_white;

out vec4 o_color;  // B, G, R: the output texture holds OpenCV's byte order

float srgb_encode(float x) {
  x = clamp(x, 0.0, 1.0);
  return x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
}

// Tutorial §4.1: the camera's response per channel (encode()).
#include "response.glsl"

void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec3 c = max(texelFetch(u_hdr, p, 0).rgb, vec3(0.0));
  vec3 outc;
#if TONE_MODE == 0
  outc = encode(c * u_exposure_gain);  // the same exposure the real pixels got
#elif TONE_MODE == 1
  // Thesis Alg. 5.5, fixed. Its line 6 reads the "average luminance" from the top MIP level
  // of the *mask* texture (texSamplerMask) instead of the illumination, i.e. it divides by
  // the covered fraction of the screen, and that level would anyway average over the whole
  // frame (background included) and arithmetically. Here L_w-bar is the log-average
  // luminance exp(mean log L_w) over the masked pixels only ([RSSF02] eq. 1). Its line 9 also
  // scales the colour by L_d, not L_d / L_w; the colour is scaled by L_d / L_w here.
  vec2 s = texelFetch(u_log_sum, ivec2(0, 0), 0).rg;
  float lavg = exp(s.x / max(s.y, 1.0));
  float lw = dot(c, vec3(0.299, 0.587, 0.114));                  // line 3
  float l = u_key * lw / lavg;                                    // line 7, eq. 5.6
  float ld = l * (1.0 + l / (u_white * u_white)) / (1.0 + l);     // line 8, eq. 5.5
  vec3 cd = lw > 0.0 ? c * (ld / lw) : vec3(0.0);
  outc = vec3(srgb_encode(cd.r), srgb_encode(cd.g), srgb_encode(cd.b));
#else
  outc = clamp(c * u_exposure_gain, 0.0, 1.0);
#endif
#if FRAME_RGB
  o_color = vec4(outc, 1.0);  // the output holds R, G, B (the browser's video frame)
#else
  o_color = vec4(outc.bgr, 1.0);  // the output holds B, G, R (an OpenCV frame)
#endif
}
