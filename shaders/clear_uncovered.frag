#version 300 es
// Radiance, coverage and mask 0 where nothing has been drawn this frame (fullscreen.vert at the
// far plane, depth test LEQUAL: only the pixels whose depth is still the cleared 1): what an
// alpha-blended surface (glTF BLEND) is blended over there. The renderer runs it before a
// frame's first blended surface instead of clearing the whole HDR target every frame.
precision mediump float;

layout(location = 0) out vec4 o_color;
layout(location = 1) out vec4 o_mask;

void main() {
  o_color = vec4(0.0);
  o_mask = vec4(0.0);
}
