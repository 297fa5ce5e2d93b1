#version 300 es
// A camera frame's planes as the browser hands them over (WebCodecs VideoFrame.copyTo): full
// resolution luma and half resolution chroma, either interleaved (NV12: u_chroma_u holds Cb, Cr in
// .rg) or planar (I420: Cb in u_chroma_u, Cr in u_chroma_v; PLANAR 1), to the camera's RGB code
// values (what a <video> upload gives). The pass draws into the renderer's camera texture with
// fullscreen.vert; row 0 of the frame is row 0 of the texture, as with the <video> upload.
// `u_from_ycbcr` and `u_offset` carry the frame's matrix (BT.601 / BT.709 / BT.2020) and range:
// rgb = u_from_ycbcr * (ycbcr - u_offset).
precision highp float;
precision highp sampler2D;

uniform sampler2D u_luma;
uniform sampler2D u_chroma_u;
uniform sampler2D u_chroma_v;
uniform mat3 u_from_ycbcr;
uniform vec3 u_offset;

out vec4 out_colour;

void main() {
  vec2 size = vec2(textureSize(u_luma, 0));
  float y = texelFetch(u_luma, ivec2(gl_FragCoord.xy), 0).r;
  // Chroma is bilinearly interpolated, sited between the luma samples (MPEG-2/JPEG centre).
  vec2 at = gl_FragCoord.xy / size;
#if PLANAR
  vec2 cbcr = vec2(texture(u_chroma_u, at).r, texture(u_chroma_v, at).r);
#else
  vec2 cbcr = texture(u_chroma_u, at).rg;
#endif
  vec3 rgb = u_from_ycbcr * (vec3(y, cbcr) - u_offset);
  out_colour = vec4(clamp(rgb, 0.0, 1.0), 1.0);
}
