#version 300 es
// Tone maps the virtual pixels over the camera frame. The renderer uploads the frame into the
// output first and runs this pass with a depth test that passes only where geometry was drawn,
// so pixels outside the mask are the camera frame's bytes exactly and cost nothing. TONE_MODE (defined by the renderer, one
// program per mode so that no pixel pays for another mode's code): 0 camera-matched,
// 1 Reinhard, 2 linear. COLOUR_MODE (dissertation §5.6, off by default): 0 none, 1 brightness,
// 2 contrast, 3 colour matching.
precision highp float;
precision highp sampler2D;

uniform sampler2D u_hdr;       // rgb radiance (premultiplied by a), a = coverage
uniform sampler2D u_response;  // encode(x) per channel at x = (i / (n-1))^2
uniform sampler2D u_log_sum;   // 1x1: (sum of log L_w, count) over the mask
uniform float u_exposure_gain;
uniform float u_key;
uniform float u_white;

#if COLOUR_MODE == 3
uniform sampler2D u_colour_sum;   // 1x1: (sum of l alpha beta, count) over the mask
uniform sampler2D u_colour_sum2;  // 1x1: (sum of squares, 0)
uniform mat3 u_lab_from_rgb;      // eq. 11a
uniform mat3 u_rgb_from_lab;
uniform vec3 u_source_mean;  // the room's horizontal regions (colour priors, §5.1), l alpha beta,
uniform vec3 u_source_sd;    // in the camera's units (radiance times exposure x gain)
#elif COLOUR_MODE != 0
uniform vec3 u_grey;  // the room's darkest side, mean and lightest side (radiance)
#endif

out vec4 o_color;  // B, G, R: the output texture holds OpenCV's byte order

float srgb_encode(float x) {
  x = clamp(x, 0.0, 1.0);
  return x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
}

// Tutorial §4.1: the camera's response per channel (encode()).
#include "response.glsl"

// The tone mapping of radiance c: what the display shows of it (codes in [0, 1], R, G, B).
vec3 tone_map(vec3 c) {
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
  return outc;
}

void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  // Coverage below 1 where only alpha-blended surfaces (glTF BLEND) are: their radiance,
  // un-premultiplied, is tone mapped and then blended over the frame by it.
  vec4 hdr = texelFetch(u_hdr, p, 0);
  float coverage = clamp(hdr.a, 0.0, 1.0);
  if (coverage < 1.0 / 1024.0) discard;
  vec3 c = max(hdr.rgb / coverage, vec3(0.0));
#if COLOUR_MODE == 3
  // Eq. 11b (Reinhard et al. 2001's transfer, in eq. 11a's space): the object's pixels, whose
  // mean and deviation were measured over the mask this frame, take the room's. The gain is
  // held within [1/4, 4]: a flat-coloured object has almost no deviation to scale.
  vec4 sum = texelFetch(u_colour_sum, ivec2(0, 0), 0);
  float n = max(sum.w, 1.0);
  vec3 t_mean = sum.xyz / n;
  vec3 t_sd = sqrt(max(texelFetch(u_colour_sum2, ivec2(0, 0), 0).xyz / n - t_mean * t_mean, 0.0));
  vec3 gain = clamp(u_source_sd / max(t_sd, vec3(1e-6)), 0.25, 4.0);
  vec3 lab = (u_lab_from_rgb * (c * u_exposure_gain) - t_mean) * gain + u_source_mean;
  c = max(u_rgb_from_lab * lab, 0.0) / u_exposure_gain;
#endif
  vec3 outc = tone_map(c);
#if COLOUR_MODE == 1 || COLOUR_MODE == 2
  // Eqs. 9 and 10 (§5.6.1) on the displayed pixel: its luma (eq. 2, BT.709) against the room's
  // greyscale priors, tone mapped like the pixel. Fixed: the dissertation multiplied the pixel by
  // the interpolated grey itself (darkening every pixel by it, and eq. 10 read literally is the
  // pixel times its own luma); here the pixel's luma becomes that grey, its colour kept.
  float s_l = tone_map(vec3(u_grey.x)).g;
  float s_m = tone_map(vec3(u_grey.y)).g;
  float s_h = tone_map(vec3(u_grey.z)).g;
  float y = dot(outc, vec3(0.2126, 0.7152, 0.0722));
#if COLOUR_MODE == 1
  float b = mix(s_l, s_h, y);  // eq. 9: the object's range onto the room's darkest..lightest
#else
  // Eqs. 10a/b, biased contrast: black to the darkest side, mid grey to the room's mean grey,
  // white to the lightest side.
  float b = y < 0.5 ? mix(s_l, s_m, 2.0 * y) : mix(s_m, s_h, 2.0 * y - 1.0);
#endif
  outc = y > 0.0 ? clamp(outc * (b / y), 0.0, 1.0) : vec3(b);
#endif
#if FRAME_RGB
  o_color = vec4(outc, coverage);  // the output holds R, G, B (the browser's video frame)
#else
  o_color = vec4(outc.bgr, coverage);  // the output holds B, G, R (an OpenCV frame)
#endif
}
