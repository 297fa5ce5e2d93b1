#version 300 es
// Image-based lighting with the Phong BRDF (thesis Alg. 5.1), light mapping (Alg. 5.2) and
// tangent-space normal mapping (Alg. 5.4). Map texels are lobe-weighted average radiance
// (Alg. 4.1), so the outgoing radiance is kd * Ld + ks * Ls.
precision highp float;
precision highp sampler2D;
precision highp samplerCube;

#include "envmap.glsl"

in vec3 v_position;
in vec3 v_normal;
in vec4 v_tangent;
in vec2 v_uv;

uniform ENV_SAMPLER u_irradiance;   // shininess 1: indexed by the normal
uniform ENV_SAMPLER u_reflection0;  // the two reflection maps around the material's shininess,
uniform ENV_SAMPLER u_reflection1;  // mixed in log shininess by u_reflection_mix
uniform float u_reflection_mix;

uniform vec3 u_camera_position;  // scene frame
uniform mat3 u_world_from_scene; // the lighting is in the world frame

uniform vec3 u_kd;
uniform vec3 u_ks;
uniform bool u_use_albedo;
uniform sampler2D u_albedo;
uniform bool u_use_normal_map;
uniform sampler2D u_normal_map;
uniform float u_normal_strength;
uniform bool u_use_light_map;
uniform sampler2D u_light_map;

layout(location = 0) out vec4 o_color;  // rgb: radiance, a: mask (1 = virtual pixel)

void main() {
  vec3 n = normalize(v_normal);  // Alg. 5.4 line 4
  if (u_use_normal_map) {
    // Alg. 5.4: t_w made orthogonal to n_w (line 5), b_w = n_w x t_w (line 6, times glTF's
    // handedness), M_TW = mat3(t, b, n) (line 7), n = M_TW n_T (line 8) with eq. 5.2 decoding.
    vec3 t = normalize(v_tangent.xyz - n * dot(n, v_tangent.xyz));
    vec3 b = v_tangent.w * cross(n, t);
    vec3 nt = texture(u_normal_map, v_uv).xyz * 2.0 - 1.0;  // lines 2-3
    nt.xy *= u_normal_strength;
    n = normalize(mat3(t, b, n) * nt);
  }
  vec3 v = normalize(u_camera_position - v_position);  // towards the eye
  vec3 r = reflect(-v, n);                              // Alg. 5.1 line 3
  // Environment lookups in the world frame (lines 2-6).
  vec3 ld = env_sample(u_irradiance, u_world_from_scene * n);
  if (u_use_light_map) ld *= texture(u_light_map, v_uv).rgb;  // Alg. 5.2 lines 7-8
  vec3 ls = vec3(0.0);
  if (u_ks != vec3(0.0)) {
    vec3 rw = u_world_from_scene * r;
    ls = mix(env_sample(u_reflection0, rw), env_sample(u_reflection1, rw), u_reflection_mix);
  }
  vec3 kd = u_kd;
  if (u_use_albedo) kd *= texture(u_albedo, v_uv).rgb;
  o_color = vec4(kd * ld + u_ks * ls, 1.0);  // Alg. 5.1 line 7
}
