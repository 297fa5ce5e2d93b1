// Environment-map lookups by direction (world frame, +Y up, -Z forward), exactly as
// common/src/projection.cpp and common/CONVENTIONS.md define them. Included by ibl.frag; the
// renderer defines ENV_PROJECTION: 0 angle map, 1 lat-long, 2 cube (stacked faces uploaded as
// a GL cube map, whose face table is the one the convention uses).

const float ENV_PI = 3.14159265358979;

// env_coord(d) computes the texture coordinate of a direction once; env_fetch samples a map
// there; env_sample(map, d) does both.

#if ENV_PROJECTION == 2
#define ENV_SAMPLER samplerCube
#define ENV_COORD vec3
vec3 env_coord(vec3 d) { return d; }
vec3 env_fetch(samplerCube s, vec3 c) { return textureLod(s, c, 0.0).rgb; }
#else
#define ENV_SAMPLER sampler2D
#define ENV_COORD vec2

#if ENV_PROJECTION == 0
// Angle map (thesis eq. 2.12 / Alg. 2.2, with its centre bug fixed): centre -Z, r = angle / pi.
vec2 env_uv(vec3 d) {
  float rho = length(d.xy);
  if (rho == 0.0) return d.z <= 0.0 ? vec2(0.5, 0.5) : vec2(0.5, 0.0);
  float r = atan(rho, -d.z) / ENV_PI;
  vec2 st = d.xy / rho * r;
  return vec2(0.5 * (st.x + 1.0), 0.5 * (1.0 - st.y));
}
#else
// Lat-long: u = 0.5 is -Z, u = 0.75 is +X, v = 0 is +Y.
vec2 env_uv(vec3 d) {
  float h = length(d.xz);
  float phi = h > 0.0 ? atan(d.x, -d.z) : 0.0;
  float el = atan(d.y, h);
  return vec2(phi / (2.0 * ENV_PI) + 0.5, 0.5 - el / ENV_PI);
}
#endif

vec2 env_coord(vec3 d) { return env_uv(d); }
vec3 env_fetch(sampler2D s, vec2 c) { return textureLod(s, c, 0.0).rgb; }
#endif

vec3 env_sample(ENV_SAMPLER s, vec3 d) { return env_fetch(s, env_coord(d)); }
