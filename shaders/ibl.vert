#version 300 es
// Thesis Alg. 5.3: positions, normals and tangents into the scene frame (the tracked marker's),
// where the fragment shader builds the tangent-to-world basis for normal mapping.
precision highp float;

layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec2 a_uv;
layout(location = 3) in vec4 a_tangent;  // xyz along +u, w = handedness (glTF)
layout(location = 4) in vec4 a_occlusion;  // baked bent normal (xyz; 0 when none), occlusion (w)

#ifdef USE_TRANSFER
// The mesh's SH-9 radiance transfer (Mesh::transfer, object frame; tutorial §6.1, Sloan et al.
// 2002's precomputed radiance transfer): coefficients 0-2, 3-5 and 6-8.
layout(location = 5) in vec3 a_transfer0;
layout(location = 6) in vec3 a_transfer1;
layout(location = 7) in vec3 a_transfer2;
uniform vec3 u_light_sh[9];  // the room's radiance SH, bands 0-2, turned into the object frame
out vec3 v_shadowing;  // the share of the lobe's light the mesh lets through, per channel

// The transfer dotted with the room's SH gives the occluded lobe radiance; over the open lobe's
// (the clamped cosine's SH, phong_zonal(l, 1) = 1, 2/3, 1/4 per band, times Y_lm(n)) it is the
// share of the light the mesh lets in: less where the bright side is the blocked one, unlike a
// uniform ambient occlusion. Bands 0-2 with the polar axis +Z (common/CONVENTIONS.md).
vec3 transfer_shadowing(vec3 n) {
  vec3 occluded = a_transfer0.x * u_light_sh[0] + a_transfer0.y * u_light_sh[1] +
                  a_transfer0.z * u_light_sh[2] + a_transfer1.x * u_light_sh[3] +
                  a_transfer1.y * u_light_sh[4] + a_transfer1.z * u_light_sh[5] +
                  a_transfer2.x * u_light_sh[6] + a_transfer2.y * u_light_sh[7] +
                  a_transfer2.z * u_light_sh[8];
  const float c0 = 0.28209479, c1 = 0.48860251, c2 = 1.09254843, c3 = 0.31539157,
              c4 = 0.54627421;
  vec3 open = c0 * u_light_sh[0] +
              (2.0 / 3.0) * c1 * (n.y * u_light_sh[1] + n.z * u_light_sh[2] + n.x * u_light_sh[3]) +
              0.25 * (c2 * n.x * n.y * u_light_sh[4] + c2 * n.y * n.z * u_light_sh[5] +
                      c3 * (3.0 * n.z * n.z - 1.0) * u_light_sh[6] +
                      c2 * n.x * n.z * u_light_sh[7] + c4 * (n.x * n.x - n.y * n.y) * u_light_sh[8]);
  // Where the lobe gets next to no light (1 % of the room's mean) the ratio means nothing.
  vec3 floor_light = vec3(0.01 * c0 * dot(u_light_sh[0], vec3(1.0 / 3.0)) + 1e-12);
  return clamp(occluded / max(open, floor_light), 0.0, 1.0);
}
#endif

uniform mat4 u_model;          // scene_from_object
uniform mat3 u_normal_matrix;  // inverse transpose of mat3(u_model) (N_m)
uniform mat4 u_view_proj;      // projection * camera_from_scene

out vec3 v_position;  // scene frame
out vec3 v_normal;    // n_w (Alg. 5.3 line 2)
out vec4 v_tangent;   // t_w (line 3) and the handedness
out vec2 v_uv;
out vec3 v_bent_normal;  // scene frame; 0 when nothing was baked
out float v_occlusion;   // the share of the cosine lobe the mesh leaves open (1: nothing baked)

void main() {
  vec4 p = u_model * vec4(a_position, 1.0);
  v_position = p.xyz;
  v_normal = u_normal_matrix * a_normal;
  // Tangents transform with the model matrix (they lie in the surface).
  v_tangent = vec4(mat3(u_model) * a_tangent.xyz, a_tangent.w);
  v_uv = a_uv;
  v_bent_normal = u_normal_matrix * a_occlusion.xyz;
  v_occlusion = a_occlusion.w;
#ifdef USE_TRANSFER
  v_shadowing = transfer_shadowing(normalize(a_normal));
#endif
  gl_Position = u_view_proj * p;  // line 5
}
