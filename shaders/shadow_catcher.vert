#version 300 es
// The shadow catcher: a rectangle of the plane z = 0 of the scene (marker) frame, drawn as a
// 4-vertex triangle strip, so only its screen footprint is shaded.
precision highp float;

uniform vec4 u_rect;        // (x0, y0, x1, y1) in the scene frame
uniform mat4 u_view_proj;   // projection * camera_from_scene

out vec3 v_position;  // scene frame, z = 0

void main() {
  vec2 p = vec2(gl_VertexID % 2 == 0 ? u_rect.x : u_rect.z, gl_VertexID < 2 ? u_rect.y : u_rect.w);
  v_position = vec3(p, 0.0);
  gl_Position = u_view_proj * vec4(p, 0.0, 1.0);
}
