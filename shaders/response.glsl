// The camera response as the renderer uploads it (tutorial §4.1): a table of encode(x) per
// channel at x = (i / (n-1))^2, linearly interpolated. Included by composite.frag and
// shadow_catcher.frag, which declare `uniform sampler2D u_response`.
vec3 encode(vec3 x) {
  float n1 = float(textureSize(u_response, 0).x - 1);
  vec3 t = sqrt(clamp(x, 0.0, 1.0)) * n1;
  ivec3 i = min(ivec3(t), ivec3(int(n1) - 1));
  vec3 f = t - vec3(i);
  float r = mix(texelFetch(u_response, ivec2(i.r, 0), 0).r, texelFetch(u_response, ivec2(i.r + 1, 0), 0).r, f.r);
  float g = mix(texelFetch(u_response, ivec2(i.g, 0), 0).g, texelFetch(u_response, ivec2(i.g + 1, 0), 0).g, f.g);
  float b = mix(texelFetch(u_response, ivec2(i.b, 0), 0).b, texelFetch(u_response, ivec2(i.b + 1, 0), 0).b, f.b);
  return vec3(r, g, b);
}
