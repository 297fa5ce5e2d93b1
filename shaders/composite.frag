#version 300 es
// Tone maps the virtual pixels and composites them over the camera frame in one pass. Pixels
// outside the mask are the camera frame's bytes exactly.
precision highp float;
precision highp sampler2D;

uniform sampler2D u_hdr;       // rgb radiance, a = mask
uniform sampler2D u_frame;     // the camera frame, 8-bit BGR bytes uploaded as RGB
uniform sampler2D u_response;  // encode(x) per channel at x = (i / (n-1))^2
uniform sampler2D u_log_sum;   // 1x1: (sum of log L_w, count) over the mask
uniform int u_mode;            // 0 camera-matched, 1 Reinhard, 2 linear
uniform float u_exposure_gain;
uniform float u_key;
uniform float u_white;

out vec4 o_color;

float srgb_encode(float x) {
  x = clamp(x, 0.0, 1.0);
  return x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
}

// Tutorial §4.1: the camera's response, from its finely sampled table.
float encode(float x, int channel) {
  int n = textureSize(u_response, 0).x;
  float t = sqrt(clamp(x, 0.0, 1.0)) * float(n - 1);
  int i = min(int(t), n - 2);
  float a = texelFetch(u_response, ivec2(i, 0), 0)[channel];
  float b = texelFetch(u_response, ivec2(i + 1, 0), 0)[channel];
  return mix(a, b, t - float(i));
}

void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec4 hdr = texelFetch(u_hdr, p, 0);
  if (hdr.a < 0.5) {
    o_color = vec4(texelFetch(u_frame, p, 0).bgr, 1.0);
    return;
  }
  vec3 c = max(hdr.rgb, vec3(0.0));
  vec3 outc;
  if (u_mode == 0) {
    vec3 x = c * u_exposure_gain;  // the same exposure the real pixels got
    outc = vec3(encode(x.r, 0), encode(x.g, 1), encode(x.b, 2));
  } else if (u_mode == 1) {
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
  } else {
    outc = clamp(c * u_exposure_gain, 0.0, 1.0);
  }
  o_color = vec4(outc, 1.0);
}
