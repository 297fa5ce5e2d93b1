#version 300 es
// Thesis Alg. 5.3: positions, normals and tangents into the scene frame (the tracked marker's),
// where the fragment shader builds the tangent-to-world basis for normal mapping.
precision highp float;

layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec2 a_uv;
layout(location = 3) in vec4 a_tangent;  // xyz along +u, w = handedness (glTF)
layout(location = 4) in vec4 a_occlusion;  // baked bent normal (xyz; 0 when none), occlusion (w)

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
  gl_Position = u_view_proj * p;  // line 5
}
