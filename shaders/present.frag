#version 300 es
// Shows the composited output in a window: flips the rows (the output's row 0 is the image's
// top, the window's row 0 its bottom) and turns stored B, G, R bytes back into RGB (bytes stored
// as R, G, B with FRAME_RGB: the browser's video frame).
precision mediump float;
precision mediump sampler2D;

uniform sampler2D u_image;
out vec4 o_color;

void main() {
  ivec2 size = textureSize(u_image, 0);
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec3 c = texelFetch(u_image, ivec2(p.x, size.y - 1 - p.y), 0).rgb;
#if FRAME_RGB
  o_color = vec4(c, 1.0);
#else
  o_color = vec4(c.bgr, 1.0);
#endif
}
