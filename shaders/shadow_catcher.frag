#version 300 es
// Shadow catcher (tutorial §6.3, differential rendering): the real floor's radiance is scaled
// by the ratio of the plane's irradiance with the virtual objects to without them,
//   ratio = 1 - f (1 - V_dir) - (1 - f) AO,
// f = the dominant light's share of the plane's irradiance (computed by the renderer),
// V_dir = its visibility from the shadow map (3x3 PCF taps, each a 2x2 bilinear comparison),
// AO = the cosine-weighted share of the rest (the sky, taken as uniform) hidden by the objects:
// baked by ray casting where an object has its floor occlusion baked (tutorial §6.1's receiver
// plane), else approximated by the ellipsoid inscribed in its bounds. The output holds the camera
// frame's codes, so the radiance ratio becomes a code ratio through the camera response around
// 18 % grey (exact for a power-law response). This pass writes those code factors at low
// resolution (B, G, R, cleared to 1); the renderer reads them back and multiplies them into
// the camera frame (bilinear upsampling) before uploading it.
precision highp float;
precision highp sampler2D;
precision highp sampler2DShadow;

in vec3 v_position;

uniform sampler2DShadow u_shadow_map;
uniform sampler2D u_response;
uniform mat4 u_shadow_from_scene;  // scene -> shadow-map texture coordinates and depth [0, 1]
uniform float u_pcf_step;          // PCF tap spacing in texture coordinates
uniform float u_depth_bias;
uniform float u_fraction;          // f, 0 when there is no directional shadow
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

float directional_visibility(vec3 p) {
  vec3 s = (u_shadow_from_scene * vec4(p, 1.0)).xyz;
  if (s.x < 0.0 || s.y < 0.0 || s.x > 1.0 || s.y > 1.0) return 1.0;
  float ref = min(s.z, 1.0) - u_depth_bias;
  float v = 0.0;
  for (int j = -1; j <= 1; ++j)
    for (int i = -1; i <= 1; ++i)
      v += texture(u_shadow_map, vec3(s.xy + vec2(float(i), float(j)) * u_pcf_step, ref));
  return v / 9.0;
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
  float v = u_fraction > 0.0 ? directional_visibility(v_position) : 1.0;
  float ao = ambient_occlusion(v_position) * u_ao_strength;
  float ratio = 1.0 - u_fraction * (1.0 - v) - (1.0 - u_fraction) * ao;
  ratio = max(ratio, u_min_ratio);
  if (ratio > 0.998) discard;  // the pass's target was cleared to 1
  vec3 grey = encode(vec3(0.18));
  vec3 factor = clamp(encode(vec3(0.18 * ratio)) / max(grey, vec3(1e-6)), 0.0, 1.0);
  o_factor = vec4(factor.bgr, 1.0);  // the output holds B, G, R
}
