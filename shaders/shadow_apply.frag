#version 300 es
// The shadow catcher's second pass: the low-resolution code factors (shadow_catcher.frag)
// upsampled bilinearly and multiplied into the output (blending dst * src) where they are
// below 1; elsewhere the fragment is discarded and the camera frame's bytes stay.
precision mediump float;
precision mediump sampler2D;

uniform sampler2D u_factor;
uniform vec2 u_scale;  // 1 / (the factor texture's size times its scale): full-res px -> uv

out vec4 o_factor;

void main() {
  vec3 f = texture(u_factor, gl_FragCoord.xy * u_scale).rgb;
  if (min(f.r, min(f.g, f.b)) > 0.999) discard;
  o_factor = vec4(f, 1.0);
}
