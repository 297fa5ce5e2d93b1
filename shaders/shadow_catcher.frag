#version 300 es
// Shadow catcher (tutorial §6.3, differential rendering): the real floor's radiance is scaled
// by the ratio of the plane's irradiance with the virtual objects to without them,
//   ratio = 1 - sum_i f_i (1 - V_i) - (1 - f) AO,   f = sum_i f_i,
// over the lights i whose hard shadows blend into the soft one (tutorial §6.3; the renderer
// picks them, §6.4): f_i = light i's share of the plane's irradiance, V_i = its visibility from
// its layer of the shadow maps (one 2x2 bilinear comparison, or 3x3 of them for one or two
// lights), AO = the share of the rest of the light hidden by the objects: where an object's
// floor transfer is baked (tutorial §6.1's receiver plane), its SH-9 transfer dotted with that
// rest as the room's SH says it comes (per channel); else the cosine-weighted share of a
// uniform sky, baked by ray casting or approximated by the ellipsoid inscribed in the object's
// bounds. The output holds the camera
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
// Where the object's floor transfer is baked too: the SH-9 transfer of what it hides (3 layers:
// coefficients 3j..3j+2 in layer j), and the rest of the room's light (what the hard shadows do
// not carry) as SH in the object's frame over what an open floor point gets from it: their dot
// product is the share of that light the object hides there, as it comes from where it comes.
uniform float u_has_ground_transfer[4];
uniform vec3 u_ground_light[36];  // object k: 9k .. 9k + 8
uniform highp sampler2DArray u_ground_transfer0;
uniform highp sampler2DArray u_ground_transfer1;
uniform highp sampler2DArray u_ground_transfer2;
uniform highp sampler2DArray u_ground_transfer3;

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

vec4 ground_transfer(int k, vec3 uvl) {
  if (k == 0) return textureLod(u_ground_transfer0, uvl, 0.0);
  if (k == 1) return textureLod(u_ground_transfer1, uvl, 0.0);
  if (k == 2) return textureLod(u_ground_transfer2, uvl, 0.0);
  return textureLod(u_ground_transfer3, uvl, 0.0);
}

// The share of the rest of the light that object k hides at p, per channel (0 outside its
// baked rectangle).
vec3 baked_hidden(int k, vec3 p) {
  vec2 uv = (u_ground_from_scene[k] * vec4(p, 1.0)).xy;
  if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) return vec3(0.0);
  vec3 hidden = vec3(0.0);
  for (int j = 0; j < 3; ++j) {
    vec3 t = ground_transfer(k, vec3(uv, float(j))).xyz;
    hidden += t.x * u_ground_light[9 * k + 3 * j] + t.y * u_ground_light[9 * k + 3 * j + 1] +
              t.z * u_ground_light[9 * k + 3 * j + 2];
  }
  return clamp(hidden, 0.0, 1.0);
}

// Occlusion of the upper hemisphere's light at p (normal +z) by the objects, per channel: by
// their baked transfer and the room's light, or cosine-weighted (the light taken as uniform)
// baked or by the ellipsoids. For a sphere of radius r at distance d whose direction makes angle theta
// with the normal, the projected solid angle over pi is exactly cos(theta) r^2 / d^2 (while the
// sphere is above the horizon); the ellipsoid uses its normalized distance |q| = |(c - p) / axes|
// for d / r.
vec3 ambient_occlusion(vec3 p) {
  vec3 ao = vec3(0.0);
  for (int k = 0; k < 4; ++k) {
    if (k >= u_count) break;
    if (u_has_ground_transfer[k] > 0.5) {
      ao += baked_hidden(k, p);
      continue;
    }
    if (u_has_ground[k] > 0.5) {
      ao += vec3(baked_ground(k, p));
      continue;
    }
    vec3 d = u_centre[k] - p;
    vec3 q = d * u_inv_axes[k];
    float cos_t = max(d.z, 0.0) / max(length(d), 1e-6);
    float fade = 1.0 - smoothstep(0.5 * u_ao_reach, u_ao_reach, length(q.xy));
    ao += vec3(cos_t / max(dot(q, q), 1.0) * fade);
  }
  return min(ao, vec3(1.0));
}

void main() {
  float hidden = 0.0;  // sum_i f_i (1 - V_i)
  for (int i = 0; i < MAX_LIGHTS; ++i) {
    if (i >= u_light_count) break;
    hidden += u_light_fraction[i / 4][i % 4] * (1.0 - visibility(i, v_position));
  }
  vec3 ao = ambient_occlusion(v_position) * u_ao_strength;
  vec3 ratio = 1.0 - hidden - (1.0 - u_fraction) * ao;
  ratio = max(ratio, vec3(u_min_ratio));
  if (all(greaterThan(ratio, vec3(0.998)))) discard;  // the pass's target was cleared to 1
  vec3 grey = encode(vec3(0.18));
  vec3 factor = clamp(encode(0.18 * ratio) / max(grey, vec3(1e-6)), 0.0, 1.0);
  o_factor = vec4(factor.bgr, 1.0);  // the output holds B, G, R
}
