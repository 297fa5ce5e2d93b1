// The compositing part of `make demo`: arlight-client's composited frames of one AR recording,
// one run per compositing mode (--shading maps, hemisphere, hemisphere-occlusion; --glass
// live), side by side: a row per picked frame, a column per mode, labelled. Drawn by headless Chromium's canvas (no
// image library needed), as the page's contact sheet is.
//   node deploy/compositing-sheet.mjs OUT.png LABEL=FRAMES_DIR...
import fs from 'node:fs';
import path from 'node:path';

import { launchChromium } from '../tests/web/harness.mjs';

if (process.argv.length < 4) {
  console.error('usage: node deploy/compositing-sheet.mjs OUT.png LABEL=FRAMES_DIR...');
  process.exit(2);
}
const out = path.resolve(process.argv[2]);
const columns = process.argv.slice(3).map((arg) => {
  const eq = arg.indexOf('=');
  if (eq <= 0) throw new Error(`'${arg}': expected LABEL=FRAMES_DIR`);
  const dir = path.resolve(arg.slice(eq + 1));
  const frames = fs.existsSync(dir) ? fs.readdirSync(dir).filter((f) => f.endsWith('.png')).sort() : [];
  if (frames.length === 0) throw new Error(`${dir}: no composited frames (PNG) in it`);
  return { label: arg.slice(0, eq), dir, frames };
});
// The frames every run has, at a quarter, a half and three quarters of the way.
const common = columns[0].frames.filter((f) => columns.every((c) => c.frames.includes(f)));
if (common.length === 0) throw new Error('the runs have no frame in common');
const picked = [0.3, 0.5, 0.7].map((t) => common[Math.min(common.length - 1, Math.floor(t * common.length))]);
const url = (file) => `data:image/png;base64,${fs.readFileSync(file).toString('base64')}`;
const cells = picked.map((f) => columns.map((c) => url(path.join(c.dir, f))));

const { browser, page } = await launchChromium();
try {
  await page.setViewportSize({ width: 1600, height: 1000 });
  await page.setContent('<body style="margin:0;background:#000"><canvas id="sheet"></canvas></body>');
  await page.evaluate(async ({ cells, labels }) => {
    const load = (u) => new Promise((resolve, reject) => {
      const img = new Image();
      img.onload = () => resolve(img);
      img.onerror = reject;
      img.src = u;
    });
    const rows = await Promise.all(cells.map((row) => Promise.all(row.map(load))));
    const w = 480;
    const h = Math.round((w * rows[0][0].height) / rows[0][0].width);
    const top = 28;
    const sheet = document.getElementById('sheet');
    sheet.width = labels.length * w;
    sheet.height = top + rows.length * h;
    const ctx = sheet.getContext('2d');
    ctx.fillStyle = '#fff';
    ctx.font = '18px sans-serif';
    labels.forEach((l, i) => ctx.fillText(l, i * w + 8, 20));
    rows.forEach((row, r) => row.forEach((img, c) => ctx.drawImage(img, c * w, top + r * h, w, h)));
  }, { cells, labels: columns.map((c) => c.label) });
  await page.locator('#sheet').screenshot({ path: out });
} finally {
  await browser.close();
}
console.log(`compositing: ${columns.map((c) => c.label).join(', ')} side by side in ${out} (frames ${picked.join(', ')})`);
