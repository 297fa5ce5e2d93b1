#version 300 es
// Shadow map of the virtual objects seen from the dominant light (orthographic): depth only.
precision highp float;

layout(location = 0) in vec3 a_position;

uniform mat4 u_light_view_proj;  // light clip from scene
uniform mat4 u_model;            // scene_from_object

void main() { gl_Position = u_light_view_proj * (u_model * vec4(a_position, 1.0)); }
