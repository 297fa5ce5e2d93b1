// The browser page's own figures in headless Chromium on SwiftShader (CPU WebGL2): frames
// composited per second and the C++ frame time (render + tone map + composite into the canvas),
// JPEG encoding, frame -> LightingUpdate latency over wss, first load; at 640x480 and 1280x720
// from Chromium's built-in fake camera, against a real arlightd on loopback. Also the size of
// the page's code (gzip). Each size with the camera frame uploaded as the <video> and as its YUV
// planes, and 640x480 with the page's own choice (upload=auto); then 1280x720 in each other
// compositing mode (hemisphere shading, glass with live refraction, colour matching). Beside the
// page's latency: arlightd's own (frame received to update sent, from its /metrics histogram) and
// the share of the page's main thread spent in long tasks (over 50 ms), where the tail waits.
// Prints a Markdown table.
//   node bench/web_page.mjs [BUILD_BIN] [SECONDS]
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import zlib from 'node:zlib';

import { launchChromium, enableOrientationOverride, overrideOrientation } from '../tests/web/harness.mjs';
import { startDaemon } from '../tests/web/phone_session.mjs';

const bin = path.resolve(process.argv[2] || 'build/bin');
const seconds = Number(process.argv[3] || 15);
const web = path.join(bin, 'web');
const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'arlight-web-bench-'));
const token = 'bench-token-0123456789';
const daemon = await startDaemon({ bin, dir: path.join(dir, 'daemon'), webRoot: web, token });

const median = (v) => {
  const s = [...v].sort((a, b) => a - b);
  return s.length ? s[Math.floor(s.length / 2)] : 0;
};
const rows = [];

// arlightd's own frame -> LightingUpdate time (received to sent): its histogram's cumulative
// bucket counts from the admin API's /metrics, {bound (s): count}.
async function updateLatencyBuckets() {
  const text = await (await daemon.adminFetch('/metrics')).text();
  const out = {};
  for (const m of text.matchAll(/^arlight_update_latency_seconds_bucket\{le="([^"]+)"\} (\d+)/gm))
    out[m[1]] = Number(m[2]);
  return out;
}
// The bucket bound (ms) under which fraction q of the updates between two readings fell.
function bucketQuantile(before, after, q) {
  const bounds = Object.keys(after).filter((b) => b !== '+Inf').sort((a, b) => Number(a) - Number(b));
  const total = after['+Inf'] - (before['+Inf'] || 0);
  for (const b of bounds) if (after[b] - (before[b] || 0) >= q * total) return 1000 * Number(b);
  return Infinity;
}
try {
  for (const [size, upload, mode = ''] of [['640x480', 'video'], ['640x480', 'yuv'], ['640x480', 'auto'],
    ['1280x720', 'video'], ['1280x720', 'yuv'], ['1280x720', 'video', 'shading=hemisphere'],
    ['1280x720', 'video', 'material=glass&refraction=live'], ['1280x720', 'video', 'colour=match']]) {
    const { browser, page } = await launchChromium();
    try {
      // The main thread's long tasks (over 50 ms): where the latency's tail waits.
      await page.addInitScript(() => {
        window.__longTasksMs = 0;
        new PerformanceObserver((list) => {
          for (const e of list.getEntries()) window.__longTasksMs += e.duration;
        }).observe({ type: 'longtask' });
      });
      await enableOrientationOverride(page);
      await overrideOrientation(page, { x: 0.5, y: 0, z: 0, w: Math.sqrt(0.75) });
      await page.goto(`${daemon.url}&autostart=1&size=${size}&upload=${upload}${mode ? `&${mode}` : ''}`);
      await page.waitForFunction(() => window.arlight.status().lighting !== 'none', null, { timeout: 60000 });
      const samples = [];
      const t0 = Date.now();
      const first = await page.evaluate(() => window.arlight.status());
      const longFirst = await page.evaluate(() => window.__longTasksMs);
      const daemonFirst = await updateLatencyBuckets();
      while (Date.now() - t0 < seconds * 1000) {
        await new Promise((r) => setTimeout(r, 250));
        samples.push(await page.evaluate(() => window.arlight.status()));
      }
      const last = samples[samples.length - 1];
      const longShare = (await page.evaluate(() => window.__longTasksMs) - longFirst) / (Date.now() - t0);
      const daemonLast = await updateLatencyBuckets();
      rows.push({
        size,
        mode: mode || 'plastic, maps',
        upload: `${upload}${upload === 'auto' ? ` (${last.upload})` : ''}`,
        track: median(samples.map((s) => s.track_ms)),
        fps: median(samples.map((s) => s.fps)),
        render: median(samples.map((s) => s.render_ms)),
        grab: median(samples.map((s) => s.grab_ms)),
        jpeg: median(samples.map((s) => s.jpeg_ms)),
        sent: last.frames_sent - first.frames_sent,
        p50: last.latency_p50_ms,
        p99: last.latency_p99_ms,
        ready: last.ready_ms,
        longShare,
        daemonP99: bucketQuantile(daemonFirst, daemonLast, 0.99),
      });
    } finally {
      await browser.close();
    }
  }
} finally {
  await daemon.stop();
  fs.rmSync(dir, { recursive: true, force: true });
}

console.log(`headless Chromium ${seconds} s per size, Chromium's fake camera at 30 fps, arlightd on loopback (wss)\n`);
console.log('| camera | mode | upload | composited fps | camera frame in | frame time (C++) | JPEG (worker) | tracking (worker) | frames sent/s | latency p50 / p99 | arlightd\'s own p99 (≤) | main thread in long tasks | first load |');
console.log('|---|---|---|---|---|---|---|---|---|---|---|---|---|');
for (const r of rows)
  console.log(`| ${r.size} | ${r.mode} | ${r.upload} | ${r.fps.toFixed(1)} | ${r.grab.toFixed(1)} ms | ${r.render.toFixed(1)} ms | ${r.jpeg.toFixed(0)} ms | ${r.track.toFixed(0)} ms | ` +
    `${(r.sent / seconds).toFixed(1)} | ${r.p50.toFixed(0)} / ${r.p99.toFixed(0)} ms | ${r.daemonP99} ms | ` +
    `${(100 * r.longShare).toFixed(0)} % | ${r.ready.toFixed(0)} ms |`);

// The page's code as a phone downloads it; opencv.js (the tracking worker's) and the models apart.
const files = fs.readdirSync(web, { withFileTypes: true })
  .filter((f) => f.isFile() && !/^opencv\.js/.test(f.name)).map((f) => f.name);
let raw = 0;
let gz = 0;
for (const f of files) {
  const b = fs.readFileSync(path.join(web, f));
  raw += b.length;
  gz += zlib.gzipSync(b, { level: 9 }).length;
}
const wasm = fs.readFileSync(path.join(web, 'arlight_web.wasm'));
console.log(`\npage code: ${files.length} files, ${(raw / 1024).toFixed(0)} KiB, ${(gz / 1024).toFixed(0)} KiB gzip ` +
  `(arlight_web.wasm ${(wasm.length / 1024).toFixed(0)} KiB, ${(zlib.gzipSync(wasm, { level: 9 }).length / 1024).toFixed(0)} KiB gzip)`);
const opencv = fs.readFileSync(path.join(web, 'opencv.js'));
console.log(`opencv.js (the tracking worker's, loaded after the page starts): ${(opencv.length / 1024).toFixed(0)} KiB, ` +
  `${(zlib.gzipSync(opencv, { level: 9 }).length / 1024).toFixed(0)} KiB gzip`);
