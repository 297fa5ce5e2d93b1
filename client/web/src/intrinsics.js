// The camera's focal length from views of the square marker: browsers do not report intrinsics,
// so the page starts from a field of view and refines it once the marker is seen.
//
// Zhang's calibration (2000) with the principal point at the image centre and square pixels,
// K = [[f, 0, cx], [0, f, cy], [0, 0, 1]]: each view's homography H = K [r1 r2 t] (marker plane
// to image, up to scale) gives two linear equations in w = 1/f^2 from the rotation's columns
// being orthogonal and of equal length. With h1, h2 the first two columns of H after moving the
// principal point to the origin:
//   (h1x h2x + h1y h2y) w + h1z h2z = 0
//   (h1x^2 + h1y^2 - h2x^2 - h2y^2) w + (h1z^2 - h2z^2) = 0
// Stacked over views and solved in least squares. A view square to the camera says nothing
// (both equations vanish); oblique ones do.

/** The homography mapping plane points (x, y) to image points (u, v), by the 4-point DLT. */
export function homography(plane, image) {
  if (plane.length !== 4 || image.length !== 4) throw new RangeError('homography: 4 points each');
  // Unknowns h0..h7 (h8 = 1): u = (h0 x + h1 y + h2) / (h6 x + h7 y + 1), likewise v.
  const a = [];
  const b = [];
  for (let i = 0; i < 4; ++i) {
    const [x, y] = plane[i];
    const [u, v] = image[i];
    a.push([x, y, 1, 0, 0, 0, -u * x, -u * y]);
    b.push(u);
    a.push([0, 0, 0, x, y, 1, -v * x, -v * y]);
    b.push(v);
  }
  const h = solve(a, b);
  return [[h[0], h[1], h[2]], [h[3], h[4], h[5]], [h[6], h[7], 1]];
}

// Gaussian elimination with partial pivoting; throws for a singular system.
function solve(a, b) {
  const n = b.length;
  const m = a.map((row, i) => [...row, b[i]]);
  for (let c = 0; c < n; ++c) {
    let p = c;
    for (let r = c + 1; r < n; ++r) if (Math.abs(m[r][c]) > Math.abs(m[p][c])) p = r;
    if (Math.abs(m[p][c]) < 1e-12) throw new RangeError('homography: degenerate points');
    [m[c], m[p]] = [m[p], m[c]];
    for (let r = 0; r < n; ++r) {
      if (r === c) continue;
      const f = m[r][c] / m[c][c];
      for (let k = c; k <= n; ++k) m[r][k] -= f * m[c][k];
    }
  }
  return m.map((row, i) => row[n] / row[i]);
}

/**
 * The focal length (pixels) that best explains the views, and how well the views determine it.
 * @param {Array<number[]>} views each the marker's 4 corners in pixels, [u0, v0, ..., u3, v3], in
 *   cv::aruco's order (top-left, top-right, bottom-right, bottom-left of the marker image)
 * @param {number} cx principal point (pixels), the image centre
 * @param {number} cy
 * @returns {{focal: number, relativeError: number}|null} f and its relative standard error (from
 *   the least-squares residuals; Infinity with a single equation), or null when the views are too
 *   square-on to tell
 */
export function focalEstimate(views, cx, cy) {
  // The marker's corners in its plane (any scale: the homography absorbs it).
  const plane = [[-1, 1], [1, 1], [1, -1], [-1, -1]];
  const rows = [];
  for (const c of views) {
    const image = [0, 1, 2, 3].map((i) => [c[2 * i] - cx, c[2 * i + 1] - cy]);
    const H = homography(plane, image);
    const h1 = [H[0][0], H[1][0], H[2][0]];
    const h2 = [H[0][1], H[1][1], H[2][1]];
    // Unweighted: a view square to the camera has both equations near 0 and so adds little
    // (scaling each to unit length would give its noise a full vote).
    rows.push([h1[0] * h2[0] + h1[1] * h2[1], h1[2] * h2[2]]);
    rows.push([h1[0] ** 2 + h1[1] ** 2 - h2[0] ** 2 - h2[1] ** 2, h1[2] ** 2 - h2[2] ** 2]);
  }
  let saa = 0;
  let sab = 0;
  for (const [a, b] of rows) {
    saa += a * a;
    sab += a * b;
  }
  if (!(saa > 0)) return null;
  const w = -sab / saa;
  if (!(w > 0)) return null;
  // var(w) = s^2 / sum(a^2) with s^2 the residuals' variance; f = w^-1/2, so df/f = dw/(2w).
  const s2 = rows.length > 1 ? rows.reduce((s, [a, b]) => s + (a * w + b) ** 2, 0) / (rows.length - 1) : Infinity;
  return { focal: 1 / Math.sqrt(w), relativeError: Math.sqrt(s2 / saa) / (2 * w) };
}

/** focalEstimate's focal length alone (null when the views cannot tell). */
export function focalFromMarkerViews(views, cx, cy) {
  const e = focalEstimate(views, cx, cy);
  return e ? e.focal : null;
}
