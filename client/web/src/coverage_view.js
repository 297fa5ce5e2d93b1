// Cells of a 36 x 18 lat-long grid the camera has looked at (its view cone), drawn as a map of
// where the capture has been and where to point next (the panel's #coverage canvas).
import { quatRotateVector } from './orientation.js';

export class CoverageView {
  constructor(canvas, fovYDeg, aspect) {
    this.ctx = canvas.getContext('2d');
    this.cols = 36;
    this.rows = 18;
    this.seen = new Uint8Array(this.cols * this.rows);
    this.setFov(fovYDeg, aspect);
    this.dirs = [];
    for (let r = 0; r < this.rows; ++r) {
      for (let c = 0; c < this.cols; ++c) {
        const phi = 2 * Math.PI * ((c + 0.5) / this.cols - 0.5);
        const el = Math.PI * (0.5 - (r + 0.5) / this.rows);
        // common/CONVENTIONS.md lat-long: u = 0.5 is -Z, v = 0 is +Y.
        this.dirs.push([Math.sin(phi) * Math.cos(el), Math.sin(el), -Math.cos(phi) * Math.cos(el)]);
      }
    }
  }
  setFov(fovYDeg, aspect) {
    const half = Math.atan(Math.tan((fovYDeg * Math.PI) / 360) * Math.min(1, aspect));
    this.cosHalf = Math.cos(half);
  }
  // A frame sent with orientation `q` (camera -> world, [w, x, y, z]): its view cone is seen.
  add(q) {
    const f = quatRotateVector(q, [0, 0, -1]);
    this.dirs.forEach((d, i) => {
      if (d[0] * f[0] + d[1] * f[1] + d[2] * f[2] >= this.cosHalf) this.seen[i] = 1;
    });
  }
  // The capture guide (issue 16 §1): the elevation (degrees, the row's centre) of the highest
  // row not yet three-quarters seen, null once every row is. A room's light comes mostly from
  // above (lamps, the sky), and arlightd's estimate of the unseen part is best once the upper
  // hemisphere is measured: swept from the ceiling down, the irradiance at 60 % coverage is
  // about twice as close to the truth as swept from the horizon out (bench/RESULTS.md).
  nextElevation() {
    for (let r = 0; r < this.rows; ++r) {
      let seen = 0;
      for (let c = 0; c < this.cols; ++c) seen += this.seen[r * this.cols + c];
      if (seen < 0.75 * this.cols) return 90 - ((r + 0.5) * 180) / this.rows;
    }
    return null;
  }
  // `next`: the guide's row (nextElevation(), or null: none drawn); `view`: arlightd's next view
  // (unit, world frame), drawn as a box where the camera should point.
  draw(forward, next, view = null) {
    const { ctx } = this;
    const w = ctx.canvas.width / this.cols;
    const h = ctx.canvas.height / this.rows;
    ctx.fillStyle = '#222';
    ctx.fillRect(0, 0, ctx.canvas.width, ctx.canvas.height);
    ctx.fillStyle = '#3fb950';
    this.seen.forEach((s, i) => {
      if (s) ctx.fillRect((i % this.cols) * w, Math.floor(i / this.cols) * h, w, h);
    });
    if (next !== null) {  // the row to sweep next, outlined
      ctx.strokeStyle = '#e3b341';
      ctx.lineWidth = 2;
      ctx.strokeRect(1, (0.5 - next / 180) * ctx.canvas.height - h / 2, ctx.canvas.width - 2, h);
      ctx.lineWidth = 1;
    }
    if (view) {  // where arlightd asks the camera to look
      const phi = Math.atan2(view[0], -view[2]);
      const el = Math.asin(Math.max(-1, Math.min(1, view[1])));
      ctx.strokeStyle = '#e3b341';
      ctx.lineWidth = 2;
      ctx.strokeRect((phi / (2 * Math.PI) + 0.5) * ctx.canvas.width - 3 * w,
        (0.5 - el / Math.PI) * ctx.canvas.height - 3 * h, 6 * w, 6 * h);
      ctx.lineWidth = 1;
    }
    if (forward) {  // where the camera looks now
      const phi = Math.atan2(forward[0], -forward[2]);
      const el = Math.asin(Math.max(-1, Math.min(1, forward[1])));
      ctx.strokeStyle = '#fff';
      ctx.strokeRect((phi / (2 * Math.PI) + 0.5) * ctx.canvas.width - 4,
        (0.5 - el / Math.PI) * ctx.canvas.height - 4, 8, 8);
    }
  }
}
