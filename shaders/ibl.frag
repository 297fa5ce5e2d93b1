#version 300 es
// Image-based lighting with the Phong BRDF (thesis Alg. 5.1), light mapping (Alg. 5.2) and
// tangent-space normal mapping (Alg. 5.4). Map texels are lobe-weighted average radiance
// (Alg. 4.1), so the outgoing radiance is kd * Ld + ks * Ls. The renderer compiles one variant per
// projection and feature set (USE_DIFFUSE, USE_ALBEDO, USE_NORMAL_MAP, USE_LIGHT_MAP,
// USE_SPECULAR, MIX_REFLECTIONS, HEMISPHERE), so no fragment pays for a feature its material
// lacks.
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
uniform sampler2D u_albedo;
uniform sampler2D u_normal_map;
uniform float u_normal_strength;
uniform sampler2D u_light_map;

#ifdef HEMISPHERE
// Hemisphere shading (dissertation §5.4): the colour priors c_u, c_l and the occlusion
// factor's range from down to up, (shadow / light, 1), or (1, 1) without occlusion.
uniform vec3 u_sky;
uniform vec3 u_ground;
uniform vec2 u_occlusion;

// Eq. 6 for a world-frame direction d, times hemisphere occlusion (§5.4.2). The blend is by
// the world's up axis: the dissertation used the camera's roll vector (§5.4.1), so the object's
// shading turned with the phone instead of staying with the room.
vec3 hemisphere(vec3 d) {
  float a = 0.5 + 0.5 * d.y;
  return mix(u_ground, u_sky, a) * mix(u_occlusion.x, u_occlusion.y, a);
}
#endif

layout(location = 0) out vec4 o_color;  // rgb: radiance
layout(location = 1) out float o_mask;  // 1 = virtual pixel (the HDR target's R8 attachment)

void main() {
  vec3 n = normalize(v_normal);  // Alg. 5.4 line 4
#ifdef USE_NORMAL_MAP
  {
    // Alg. 5.4: t_w made orthogonal to n_w (line 5), b_w = n_w x t_w (line 6, times glTF's
    // handedness), M_TW = mat3(t, b, n) (line 7), n = M_TW n_T (line 8) with eq. 5.2 decoding.
    vec3 t = normalize(v_tangent.xyz - n * dot(n, v_tangent.xyz));
    vec3 b = v_tangent.w * cross(n, t);
    vec3 nt = texture(u_normal_map, v_uv).xyz * 2.0 - 1.0;  // lines 2-3
    nt.xy *= u_normal_strength;
    n = normalize(mat3(t, b, n) * nt);
  }
#endif
  vec3 lo = vec3(0.0);
#ifdef USE_DIFFUSE
  // Environment lookups in the world frame (Alg. 5.1 lines 2-6).
#ifdef HEMISPHERE
  vec3 ld = hemisphere(normalize(u_world_from_scene * n));
#else
  vec3 ld = env_sample(u_irradiance, u_world_from_scene * n);
#endif
#ifdef USE_LIGHT_MAP
  ld *= texture(u_light_map, v_uv).rgb;  // Alg. 5.2 lines 7-8
#endif
  vec3 kd = u_kd;
#ifdef USE_ALBEDO
  kd *= texture(u_albedo, v_uv).rgb;
#endif
  lo += kd * ld;
#endif
#ifdef USE_SPECULAR
  vec3 v = normalize(u_camera_position - v_position);  // towards the eye
  vec3 r = u_world_from_scene * reflect(-v, n);         // Alg. 5.1 line 3
#ifdef HEMISPHERE
  vec3 ls = hemisphere(normalize(r));
#else
  ENV_COORD cr = env_coord(r);                          // line 4, once for both maps
  vec3 ls = env_fetch(u_reflection0, cr);
#ifdef MIX_REFLECTIONS
  ls = mix(ls, env_fetch(u_reflection1, cr), u_reflection_mix);
#endif
#endif
  lo += u_ks * ls;
#endif
  o_color = vec4(lo, 1.0);  // Alg. 5.1 line 7
  o_mask = 1.0;
}
