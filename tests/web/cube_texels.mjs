// Cube-map texels as common/CONVENTIONS.md lays them out (GL's cube table: faces +X, -X, +Y, -Y,
// +Z, -Z, each row-major from its first row), for the browser tests that check what WebGL
// samples against what a file or the wire holds.

/** An IEEE half float's value. */
export function halfToFloat(h) {
  const s = h & 0x8000 ? -1 : 1, e = (h >> 10) & 0x1f, m = h & 0x3ff;
  if (e === 0) return s * m * 2 ** -24;
  return s * (1 + m / 1024) * 2 ** (e - 15);
}

/** The texel (face, column i, row j) of an n x n face that direction [x, y, z] falls in. */
export function cubeTexel(n, [x, y, z]) {
  const ax = Math.abs(x), ay = Math.abs(y), az = Math.abs(z);
  let face, sc, tc, ma;
  if (ax >= ay && ax >= az) [face, sc, tc, ma] = x > 0 ? [0, -z, -y, ax] : [1, z, -y, ax];
  else if (ay >= az) [face, sc, tc, ma] = y > 0 ? [2, x, z, ay] : [3, x, -z, ay];
  else [face, sc, tc, ma] = z > 0 ? [4, x, -y, az] : [5, -x, -y, az];
  const i = Math.min(n - 1, Math.floor(((sc / ma + 1) / 2) * n));
  const j = Math.min(n - 1, Math.floor(((tc / ma + 1) / 2) * n));
  return { face, i, j };
}

/** The direction through the centre of texel (face, i, j) of an n x n face: cubeTexel's inverse. */
export function texelDirection(n, face, i, j) {
  const u = (2 * (i + 0.5)) / n - 1, v = (2 * (j + 0.5)) / n - 1;
  return [[1, -v, -u], [-1, -v, u], [u, 1, v], [u, -1, -v], [u, -v, 1], [-u, -v, -1]][face];
}

/** RGB of texel (face, i, j) in half-float RGBA faces stacked one after another (8 bytes each). */
export function halfRgbaTexel(view, n, { face, i, j }) {
  const at = ((face * n + j) * n + i) * 8;
  return [0, 1, 2].map((c) => halfToFloat(view.getUint16(at + 2 * c, true)));
}
