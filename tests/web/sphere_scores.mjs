// arlight-bench-pbr's figures for a sphere another renderer drew (bench/RESULTS.md, issue 34
// part 3): against the reference's traced pixels ({pixels: [[x, y, r, g, b], ...]}, y down), the
// mean relative error (thesis eq. 6.1 over the channels, eps = 1e-4 x the reference's mean), the
// mean absolute error over the mean radiance, and PSNR with the reference's brightest value as
// the peak. `rgba`: linear RGBA floats of a width x height view, rows bottom-up (WebGL's).
export function scoreSphere(reference, rgba, width, height) {
  let meanRef = 0, peak = 0;
  for (const [, , r, g, b] of reference.pixels) meanRef += r + g + b, peak = Math.max(peak, r, g, b);
  meanRef /= 3 * reference.pixels.length;
  const eps = 1e-4 * meanRef;
  let mean = 0, weighted = 0, se = 0, values = 0;
  for (const [x, y, ...want] of reference.pixels) {
    const at = 4 * ((height - 1 - y) * width + x);
    for (let c = 0; c < 3; ++c) {
      const got = rgba[at + c];
      mean += Math.abs(got - want[c]) / (want[c] + eps);
      weighted += Math.abs(got - want[c]);
      se += (got - want[c]) ** 2;
      ++values;
    }
  }
  return { mean: mean / values, weighted: weighted / values / meanRef,
    psnr_db: 10 * Math.log10((peak * peak) / Math.max(se / values, 1e-30)) };
}

/** A Markdown cell: mean relative error; mean absolute error over the mean; PSNR. */
export const scoreCell = (f) =>
  `${(100 * f.mean).toFixed(1)} %; ${(100 * f.weighted).toFixed(1)} %; ${f.psnr_db.toFixed(1)} dB`;
