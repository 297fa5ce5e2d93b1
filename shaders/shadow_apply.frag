#version 300 es
// The shadow catcher's factors multiplied into the camera frame on the GPU (the browser's path,
// Renderer::composite_in_place: the frame never leaves the GPU there). Drawn over the catcher's
// rectangle (shadow_catcher.vert) into the output with the blend dst * src; the factors are the
// low-resolution ones of shadow_catcher.frag, upsampled bilinearly with the texel centres where
// composite()'s CPU path puts them, so both paths darken the same pixels by the same amount.
precision highp float;

uniform sampler2D u_factors;  // B, G, R factors at 1/scale of the output, 1 where no shadow
uniform vec2 u_factor_extent;  // the factor texture's size times the scale, in output pixels

out vec4 o_colour;

void main() {
  vec3 f = texture(u_factors, gl_FragCoord.xy / u_factor_extent).rgb;
#ifdef FRAME_RGB
  o_colour = vec4(f.bgr, 1.0);  // the output holds the browser's R, G, B
#else
  o_colour = vec4(f, 1.0);
#endif
}
