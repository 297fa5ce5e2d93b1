#version 300 es
// Shadow catcher (tutorial §6.3, differential rendering): the real floor's radiance is scaled
// by the ratio of the plane's irradiance with the virtual objects to without them,
//   ratio = 1 - sum_i f_i (1 - V_i) - (1 - f) AO,   f = sum_i f_i,
// over the lights i whose hard shadows blend into the soft one (tutorial §6.3; the renderer
// picks them, §6.4): f_i = light i's share of the plane's irradiance, V_i = its visibility from
// its layer of the shadow maps (one 2x2 bilinear comparison, or 3x3 of them for one or two
// lights), AO = the cosine-weighted share of the rest (the sky, taken as uniform) hidden by the
// objects:
// baked by ray casting where an object has its floor occlusion baked (tutorial §6.1's receiver
// plane), else approximated by the ellipsoid inscribed in its bounds. The output holds the camera
// frame's codes, so the radiance ratio becomes a code ratio through the camera response around
// 18 % grey (exact for a power-law response). This pass writes those code factors at low
// resolution (B, G, R, cleared to 1); the renderer multiplies them into the camera frame,
// upsampled bilinearly: read back, on the CPU before the frame's upload (composite()), or on
// the GPU by blending (shadow_apply.frag, composite_in_place()).
precision highp float;
precision highp sampler2D;
precision highp sampler2DArrayShadow;

#define MAX_LIGHTS 32  // render.hpp's kMaxShadowLights

in vec3 v_position;

uniform sampler2DArrayShadow u_shadow_maps;  // layer i: light i's depth
uniform sampler2D u_response;
uniform int u_light_count;
uniform mat4 u_shadow_from_scene[MAX_LIGHTS];  // scene -> light i's texture coords, depth [0, 1]
uniform vec4 u_light_fraction[MAX_LIGHTS / 4];  // f_i, four to a vec4
uniform int u_pcf_radius;          // 0: one bilinear comparison; 1: 3x3 of them
uniform float u_pcf_step;          // PCF tap spacing in texture coordinates
uniform float u_depth_bias;
uniform float u_fraction;          // f = sum f_i (0 without lights)
uniform float u_ao_strength;
uniform float u_ao_reach;          // AO fades to 0 at this many half-extents, horizontally
uniform float u_min_ratio;
uniform int u_count;               // ellipsoids
uniform vec3 u_centre[4];
uniform vec3 u_inv_axes[4];        // 1 / semi-axes
uniform float u_has_ground[4];     // 1: the object's floor occlusion is baked (u_groundK)
uniform mat4 u_ground_from_scene[4];  // scene point -> (u, v) of its baked floor
uniform sampler2D u_ground0;       // R: the share of the sky the object hides (R8)
uniform sampler2D u_ground1;
uniform sampler2D u_ground2;
uniform sampler2D u_ground3;

out vec4 o_factor;

#include "response.glsl"

float visibility(int light, vec3 p) {
  vec3 s = (u_shadow_from_scene[light] * vec4(p, 1.0)).xyz;
  if (s.x < 0.0 || s.y < 0.0 || s.x > 1.0 || s.y > 1.0) return 1.0;
  float ref = min(s.z, 1.0) - u_depth_bias;
  float v = 0.0, n = 0.0;
  for (int j = -u_pcf_radius; j <= u_pcf_radius; ++j)
    for (int i = -u_pcf_radius; i <= u_pcf_radius; ++i) {
      vec2 uv = s.xy + vec2(float(i), float(j)) * u_pcf_step;
      v += texture(u_shadow_maps, vec4(uv, float(light), ref));
      n += 1.0;
    }
  return v / n;
}

// The baked floor of object k at p (0 outside its rectangle, where it hides next to nothing).
// textureLod: no derivatives in the branches that pick the sampler.
float baked_ground(int k, vec3 p) {
  vec2 uv = (u_ground_from_scene[k] * vec4(p, 1.0)).xy;
  if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) return 0.0;
  if (k == 0) return textureLod(u_ground0, uv, 0.0).r;
  if (k == 1) return textureLod(u_ground1, uv, 0.0).r;
  if (k == 2) return textureLod(u_ground2, uv, 0.0).r;
  return textureLod(u_ground3, uv, 0.0).r;
}

// Cosine-weighted occlusion of the upper hemisphere at p (normal +z) by the objects: baked, or
// by the ellipsoids. For a sphere of radius r at distance d whose direction makes angle theta
// with the normal, the projected solid angle over pi is exactly cos(theta) r^2 / d^2 (while the
// sphere is above the horizon); the ellipsoid uses its normalized distance |q| = |(c - p) / axes|
// for d / r.
float ambient_occlusion(vec3 p) {
  float ao = 0.0;
  for (int k = 0; k < 4; ++k) {
    if (k >= u_count) break;
    if (u_has_ground[k] > 0.5) {
      ao += baked_ground(k, p);
      continue;
    }
    vec3 d = u_centre[k] - p;
    vec3 q = d * u_inv_axes[k];
    float cos_t = max(d.z, 0.0) / max(length(d), 1e-6);
    float fade = 1.0 - smoothstep(0.5 * u_ao_reach, u_ao_reach, length(q.xy));
    ao += cos_t / max(dot(q, q), 1.0) * fade;
  }
  return min(ao, 1.0);
}

void main() {
  float hidden = 0.0;  // sum_i f_i (1 - V_i)
  for (int i = 0; i < MAX_LIGHTS; ++i) {
    if (i >= u_light_count) break;
    hidden += u_light_fraction[i / 4][i % 4] * (1.0 - visibility(i, v_position));
  }
  float ao = ambient_occlusion(v_position) * u_ao_strength;
  float ratio = 1.0 - hidden - (1.0 - u_fraction) * ao;
  ratio = max(ratio, u_min_ratio);
  if (ratio > 0.998) discard;  // the pass's target was cleared to 1
  vec3 grey = encode(vec3(0.18));
  vec3 factor = clamp(encode(vec3(0.18 * ratio)) / max(grey, vec3(1e-6)), 0.0, 1.0);
  o_factor = vec4(factor.bgr, 1.0);  // the output holds B, G, R
}
