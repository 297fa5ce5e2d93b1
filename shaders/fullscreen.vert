#version 300 es
// One triangle covering the viewport, at the far plane (z = 1) so that a GL_GREATER depth test
// keeps only pixels where geometry was drawn; the fragment shaders address texels with
// gl_FragCoord.
void main() {
  vec2 p = vec2(gl_VertexID == 1 ? 3.0 : -1.0, gl_VertexID == 2 ? 3.0 : -1.0);
  gl_Position = vec4(p, 1.0, 1.0);
}
