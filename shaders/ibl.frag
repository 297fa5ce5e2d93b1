#version 300 es
// Image-based lighting with the Phong BRDF (thesis Alg. 5.1), light mapping (Alg. 5.2) and
// tangent-space normal mapping (Alg. 5.4). Map texels are lobe-weighted average radiance
// (Alg. 4.1), so the outgoing radiance is kd * Ld + ks * Ls. METALLIC_ROUGHNESS shades glTF 2.0's
// metallic-roughness instead, with the split sum (Karis 2013; Filament): the GGX chain (or, without
// GGX_CHAIN, the reflection maps) times the DFG table's specular albedo, Kulla & Conty's
// multiple-scattering lobe and the Lambertian part lit by the irradiance. The renderer compiles
// one variant per projection and feature set (USE_DIFFUSE, USE_ALBEDO, USE_NORMAL_MAP,
// USE_LIGHT_MAP, USE_SPECULAR, MIX_REFLECTIONS, HEMISPHERE, GLASS, LIVE_REFRACTION, FRAME_RGB,
// METALLIC_ROUGHNESS, GGX_CHAIN, GGX_DIFFUSE, GGX_LIGHTS, USE_MR_MAP, USE_OCCLUSION_MAP, USE_EMISSIVE_MAP,
// ALPHA_MASK), so no fragment pays for a feature its material lacks.
precision highp float;
precision highp sampler2D;
precision highp samplerCube;

#include "envmap.glsl"

in vec3 v_position;
in vec3 v_normal;
in vec4 v_tangent;
in vec2 v_uv;
in vec3 v_bent_normal;
in float v_occlusion;
#ifdef USE_TRANSFER
in vec3 v_shadowing;  // ibl.vert: the share of the light the mesh lets in (its SH-9 transfer)
#endif

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

#ifdef METALLIC_ROUGHNESS
// glTF 2.0 pbrMetallicRoughness (arlight/render/material.hpp MetallicRoughness).
uniform vec4 u_base_colour;          // linear RGBA, times the base colour texture (u_albedo)
uniform vec2 u_metallic_roughness;   // factors, times the texture's B and G
uniform sampler2D u_mr_map;
uniform sampler2D u_occlusion_map;   // R
uniform float u_occlusion_strength;
uniform vec3 u_emissive;
uniform sampler2D u_emissive_map;
uniform float u_alpha_cutoff;
uniform sampler2D u_dfg;             // the split sum's (a, b, E_avg) at (n.v, 1 - roughness)
#ifdef GGX_CHAIN
uniform samplerCube u_ggx;           // mip level k: roughness 1 - sqrt(1 - k / max_lod)
uniform float u_ggx_max_lod;         // levels - 1
#endif
#ifdef GGX_LIGHTS  // only with GGX_CHAIN: the chain is the room less these lights
const int MAX_GGX_LIGHTS = 8;        // arlight/common/specular_lights.hpp kMaxSpecularLights
uniform int u_ggx_light_count;
uniform vec3 u_ggx_light_direction[MAX_GGX_LIGHTS];  // world frame, unit, towards the light
uniform vec3 u_ggx_light_power[MAX_GGX_LIGHTS];      // its irradiance at normal incidence
uniform vec3 u_ggx_light_disc[MAX_GGX_LIGHTS];  // its disc's angular radius: (cos, sin, rad)
#endif
#endif

// The irradiance map's value (irradiance / pi) at a world-frame normal. GGX_DIFFUSE (a
// metallic-roughness material with the room's GGX chain and no map set) takes it from the
// chain's roughest level: roughness 1's prefilter is the cosine-weighted mean, the irradiance
// map itself, as fresh as the chain (though at its face, 16).
vec3 irradiance(vec3 d) {
#ifdef GGX_DIFFUSE  // only with METALLIC_ROUGHNESS and GGX_CHAIN
  vec3 e = textureLod(u_ggx, d, u_ggx_max_lod).rgb;
#ifdef GGX_LIGHTS  // the residual's: the lights taken out of it give theirs
  vec3 n = normalize(d);
  for (int i = 0; i < MAX_GGX_LIGHTS; ++i) {
    if (i >= u_ggx_light_count) break;
    e += u_ggx_light_power[i] * (max(dot(n, u_ggx_light_direction[i]), 0.0) / ENV_PI);
  }
#endif
  return e;
#else
  return env_sample(u_irradiance, d);
#endif
}

#ifdef GGX_CHAIN
// The chain's radiance for the lobe at r (world frame; n the normal) (issue 51 §1). The chain
// holds the n = v = R lobe, isotropic about R; the BRDF's is as wide in the plane of incidence
// but n.v times as narrow across it (the half vector's Jacobian: tilting h across the plane
// moves l by 2 (v.h), in it by 2). So two taps of the narrower lobe, either side of r along the
// plane of incidence by GRAZING_SPREAD x the widths' difference, stand for it; head-on (n.v = 1)
// they are one tap of the chain's own lobe (three taps, 1/4 1/2 1/4, measured the same). Rough
// lobes are not that narrow (the Jacobian is a small-angle one): the narrowing fades out as
// roughness goes to 1. GRAZING_SPREAD and the
// fade were chosen against the full BRDF (arlight-bench-pbr: bench/RESULTS.md, issue 51).
const float GRAZING_SPREAD = 1.4 * 0.70710678;
vec3 chain_radiance(vec3 r, vec3 n, float roughness, float nv) {
  float a = roughness * roughness;
  float a_across = a * mix(1.0, max(nv, 0.05), 1.0 - roughness);
  float r_across = sqrt(a_across);
  float lod = u_ggx_max_lod * r_across * (2.0 - r_across);
  vec3 t = n - dot(n, r) * r;
  float tl = length(t);
  t = tl > 1e-4 ? t / tl : vec3(0.0);
  vec3 offset = GRAZING_SPREAD * sqrt(a * a - a_across * a_across) * t;
  vec3 p = textureLod(u_ggx, normalize(r + offset), lod).rgb;
  vec3 m = textureLod(u_ggx, normalize(r - offset), lod).rgb;
  return 0.5 * (p + m);
}
#endif

#ifdef GGX_LIGHTS
// glTF's GGX specular (arlight/common/brdf.hpp: D, the height-correlated Smith V, Schlick's F)
// of the lights taken out of the chain's room, world frame (issue 51 §1). Each is a disc:
// Karis 2013's representative point (the disc's direction nearest the mirror direction r) with
// the lobe's normalisation for the disc's widening, (alpha / alpha')^2, alpha' = alpha +
// radius / 2 (a mirror facing the viewer then shows the disc's own radiance).
vec3 ggx_lights(vec3 n, vec3 v, float nv, float alpha, vec3 f0) {
  vec3 r = reflect(-v, n);
  float a2 = alpha * alpha;
  vec3 sum = vec3(0.0);
  for (int i = 0; i < MAX_GGX_LIGHTS; ++i) {
    if (i >= u_ggx_light_count) break;
    vec3 c = u_ggx_light_direction[i];
    vec3 disc = u_ggx_light_disc[i];
    float rc = dot(r, c);
    vec3 across = r - rc * c;
    float len = length(across);
    vec3 l = rc >= disc.x ? r : (len > 1e-6 ? disc.x * c + disc.y / len * across : c);
    float nl = dot(n, l);
    if (nl <= 0.0) continue;
    vec3 h = normalize(v + l);
    float nh = clamp(dot(n, h), 0.0, 1.0), vh = clamp(dot(v, h), 0.0, 1.0);
    float dd = nh * nh * (a2 - 1.0) + 1.0;
    float d = a2 / (ENV_PI * dd * dd);
    float wide = alpha / min(1.0, alpha + 0.5 * disc.z);
    float vis = 0.5 / (nl * sqrt(nv * nv * (1.0 - a2) + a2) + nv * sqrt(nl * nl * (1.0 - a2) + a2));
    float fc = 1.0 - vh, fc2 = fc * fc;
    vec3 f = f0 + (1.0 - f0) * (fc2 * fc2 * fc);
    sum += u_ggx_light_power[i] * f * (d * wide * wide * vis * nl);
  }
  return sum;
}
#endif

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

// The reflection maps (or eq. 6) in a world-frame direction: what a mirror-like lobe sees.
vec3 specular_environment(vec3 d) {
#ifdef HEMISPHERE
  return hemisphere(normalize(d));
#else
  ENV_COORD c = env_coord(d);  // once for both maps
  vec3 l = env_fetch(u_reflection0, c);
#ifdef MIX_REFLECTIONS
  l = mix(l, env_fetch(u_reflection1, c), u_reflection_mix);
#endif
  return l;
#endif
}

#ifdef GLASS
// Glass (dissertation §5.5.1, done with both interfaces and Fresnel): the view ray refracts into
// the object at this fragment, crosses it to the far side of the ellipsoid inscribed in the
// mesh's bounds (exact for a sphere, the thickness of anything else), and refracts out. The
// dissertation drew glass as specular highlights over the background with one refract() through
// a "negative-angle" environment matrix; here Snell's law holds at both surfaces, the Fresnel
// term splits reflection from transmission, and what is seen through the object is the
// environment (the maps) or, with LIVE_REFRACTION, the camera frame itself (§5.5.3).
uniform float u_ior;                // index of refraction (the object's over air's)
uniform vec3 u_transmission;        // the share of the refracted light that gets through (tint)
uniform mat4 u_object_from_scene;   // inverse of u_model
uniform vec3 u_ellipsoid_centre;    // object frame: the centre of the mesh's bounds
uniform vec3 u_ellipsoid_axes;      // object frame: half its extents

// Unpolarised Fresnel reflectance of a dielectric interface, for the cosine of the angle of
// incidence and eta = n_incident / n_transmitted; 1 under total internal reflection.
float fresnel(float cos_i, float eta) {
  float sin2_t = eta * eta * (1.0 - cos_i * cos_i);
  if (sin2_t >= 1.0) return 1.0;
  float cos_t = sqrt(1.0 - sin2_t);
  float rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  float rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  return 0.5 * (rs * rs + rp * rp);
}

#ifdef LIVE_REFRACTION
// Dissertation §5.5.3, live refraction: what the camera sees behind the object, looked up in a
// copy of this frame's camera image (uploaded once per frame as a texture; the dissertation
// re-encoded every frame as a PNG). The ray leaving the object ends on the real floor (the plane
// z = 0 of the scene, where the shadow catcher is) when it goes down to it, else far away.
uniform mat4 u_view_proj;
uniform sampler2D u_frame;             // the camera frame's codes, top row first
uniform sampler2D u_response_inverse;  // 256 x 1: linear exposure of each code, per channel
uniform float u_inv_exposure_gain;     // 1 / (the frame's exposure x gain): codes to radiance

vec3 decode(vec3 code) {
  vec3 x = clamp(code, 0.0, 1.0) * 255.0;
  ivec3 i = min(ivec3(x), ivec3(254));
  vec3 f = x - vec3(i);
  return vec3(
      mix(texelFetch(u_response_inverse, ivec2(i.r, 0), 0).r,
          texelFetch(u_response_inverse, ivec2(i.r + 1, 0), 0).r, f.r),
      mix(texelFetch(u_response_inverse, ivec2(i.g, 0), 0).g,
          texelFetch(u_response_inverse, ivec2(i.g + 1, 0), 0).g, f.g),
      mix(texelFetch(u_response_inverse, ivec2(i.b, 0), 0).b,
          texelFetch(u_response_inverse, ivec2(i.b + 1, 0), 0).b, f.b));
}

// The frame's radiance behind the object along the ray x + s d (scene frame), or false when the
// ray leaves the frame (the maps show then).
bool frame_radiance(vec3 x, vec3 d, out vec3 radiance) {
  vec4 clip = d.z < 0.0 && x.z > 0.0 ? u_view_proj * vec4(x - d * (x.z / d.z), 1.0)
                                     : u_view_proj * vec4(d, 0.0);
  if (clip.w <= 0.0) return false;
  vec2 uv = 0.5 * clip.xy / clip.w + 0.5;  // the targets' row 0 is the image's top row
  if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) return false;
  vec3 code = texture(u_frame, uv).rgb;
#if !FRAME_RGB
  code = code.bgr;  // a native frame holds B, G, R
#endif
  radiance = decode(code) * u_inv_exposure_gain;
  return true;
}
#endif
#endif

layout(location = 0) out vec4 o_color;  // rgb: radiance
// 1 = virtual pixel (the HDR target's R8 attachment: .r; a = 1, so that a blended draw keeps 1)
layout(location = 1) out vec4 o_mask;

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
  float coverage = 1.0;  // ALPHA_BLEND: the base colour's alpha
#ifdef USE_DIFFUSE
  // Environment lookups in the world frame (Alg. 5.1 lines 2-6). Where the mesh's transfer is
  // baked (tutorial §6.1) the irradiance at the normal is scaled by the share of the room's
  // light the mesh lets in (ibl.vert); where only its occlusion is, the light comes along the
  // bent normal (the open directions' mean; a normal map's tilt kept) and only its open share:
  // the ambient occlusion.
#ifdef USE_TRANSFER
  vec3 ld = irradiance(u_world_from_scene * n) * v_shadowing;
#else
  vec3 d = n;
  if (dot(v_bent_normal, v_bent_normal) > 1e-8)
    d = normalize(n + normalize(v_bent_normal) - normalize(v_normal));
#ifdef HEMISPHERE
  vec3 ld = hemisphere(normalize(u_world_from_scene * d)) * v_occlusion;
#else
  vec3 ld = irradiance(u_world_from_scene * d) * v_occlusion;
#endif
#endif  // USE_TRANSFER
#ifdef USE_LIGHT_MAP
  ld *= texture(u_light_map, v_uv).rgb;  // Alg. 5.2 lines 7-8
#endif
#ifndef METALLIC_ROUGHNESS
  vec3 kd = u_kd;
#ifdef USE_ALBEDO
  kd *= texture(u_albedo, v_uv).rgb;
#endif
  lo += kd * ld;
#endif
#endif
#ifdef METALLIC_ROUGHNESS
  {
    vec4 base = u_base_colour;
#ifdef USE_ALBEDO
    base *= texture(u_albedo, v_uv);
#endif
#ifdef ALPHA_MASK
    if (base.a < u_alpha_cutoff) discard;
#endif
    coverage = clamp(base.a, 0.0, 1.0);
    vec2 mr = u_metallic_roughness;
#ifdef USE_MR_MAP
    mr *= texture(u_mr_map, v_uv).bg;
#endif
    float metallic = clamp(mr.x, 0.0, 1.0), roughness = clamp(mr.y, 0.0, 1.0);
    vec3 v = normalize(u_camera_position - v_position);
    float nv = clamp(dot(n, v), 1e-4, 1.0);  // interpolated normals at the silhouette may face away
    // The split sum: single scattering is the prefiltered radiance times the specular albedo
    // E = mix(a, b, F0) of the DFG table. What it loses comes back as Kulla & Conty's
    // multiple-scattering lobe F_ms (1 - E(n.v)) (1 - E(n.l)) / (pi (1 - E_avg)) (common/brdf.hpp),
    // whose integral over the room is taken as the irradiance map's cosine-weighted mean times
    // pi (1 - E_avg): a white metal in a constant room reflects it exactly. The diffuse part,
    // the dielectric's (glTF's fresnel_mix), keeps what its own specular (F0 = 0.04) leaves.
    vec3 dfg = texture(u_dfg, vec2(nv, 1.0 - roughness)).rgb;  // a, b, E_avg
    vec3 f0 = mix(vec3(0.04), base.rgb, metallic);
    vec3 e = mix(dfg.xxx, dfg.yyy, f0);
    vec3 f_avg = (20.0 * f0 + 1.0) / 21.0;
    vec3 f_ms = f_avg * f_avg * dfg.z / (1.0 - f_avg * (1.0 - dfg.z));
    // The lobe's dominant direction leans from the mirror direction towards the normal as the
    // surface roughens (Lagarde & de Rousiers 2014, Frostbite; Filament's
    // getSpecularDominantDirection): the prefilter's n = v = R lobe is centred on R, the BRDF's
    // is not, most at grazing views.
    vec3 r = u_world_from_scene * normalize(mix(reflect(-v, n), n, roughness * roughness));
#ifdef GGX_CHAIN
    vec3 n_world = u_world_from_scene * n;
    vec3 ls = chain_radiance(r, n_world, roughness, nv);
#else
    vec3 ls = specular_environment(r);
#endif
    float e_dielectric = mix(dfg.x, dfg.y, 0.04);
    lo = base.rgb * (1.0 - metallic) * (1.0 - e_dielectric) * ld + e * ls +
         f_ms * (1.0 - dfg.y) * ld;
#ifdef GGX_LIGHTS
    lo += ggx_lights(n_world, u_world_from_scene * v, nv, max(roughness * roughness, 1e-3), f0);
#endif
#ifdef USE_OCCLUSION_MAP
    lo *= 1.0 + u_occlusion_strength * (texture(u_occlusion_map, v_uv).r - 1.0);
#endif
    vec3 emitted = u_emissive;
#ifdef USE_EMISSIVE_MAP
    emitted *= texture(u_emissive_map, v_uv).rgb;
#endif
    lo += emitted;
  }
#endif
#if defined(USE_SPECULAR) || defined(GLASS)
  vec3 v = normalize(u_camera_position - v_position);  // towards the eye
#ifdef GLASS
  n = faceforward(n, -v, n);  // interpolated normals at the silhouette may face away
#endif
  vec3 r = u_world_from_scene * reflect(-v, n);         // Alg. 5.1 line 3
  vec3 ls = specular_environment(r);
#ifdef GLASS
  float f_in = fresnel(dot(n, v), 1.0 / u_ior);
  lo += f_in * ls;
  // Through the object: in at this point, out where the ray leaves the inscribed ellipsoid.
  vec3 t_in = refract(-v, n, 1.0 / u_ior);
  vec3 q = ((u_object_from_scene * vec4(v_position, 1.0)).xyz - u_ellipsoid_centre) /
           u_ellipsoid_axes;
  vec3 e = mat3(u_object_from_scene) * t_in / u_ellipsoid_axes;
  float ee = dot(e, e), qe = dot(q, e);
  float s = max(0.0, (-qe + sqrt(max(0.0, qe * qe - ee * (dot(q, q) - 1.0)))) / ee);
  vec3 x_out = v_position + s * t_in;  // the map to the object frame is linear: s is shared
  vec3 n_out = normalize(transpose(mat3(u_object_from_scene)) *
                         ((q + s * e) / u_ellipsoid_axes));  // the ellipsoid's outward normal
  vec3 t_out = refract(t_in, -n_out, u_ior);
  float f_out = fresnel(max(dot(t_in, n_out), 0.0), u_ior);
  if (t_out == vec3(0.0)) {
    // Total internal reflection: the light is taken to leave after this one bounce.
    t_out = reflect(t_in, -n_out), f_out = 0.0;
  }
  vec3 through = u_transmission * (1.0 - f_in) * (1.0 - f_out);
  vec3 behind;
#ifdef LIVE_REFRACTION
  if (!frame_radiance(x_out, t_out, behind))
#endif
    behind = specular_environment(u_world_from_scene * t_out);
  lo += through * behind;
#else
  lo += u_ks * ls;
#endif
#endif
#ifdef ALPHA_BLEND
  o_color = vec4(lo * coverage, coverage);  // premultiplied, blended over what is behind
#else
  o_color = vec4(lo, 1.0);  // Alg. 5.1 line 7
#endif
  o_mask = vec4(1.0);
}
