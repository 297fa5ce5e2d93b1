// The phone page through a shaped link (issue 36 §3; run by bench/shaped_links.sh): arlightd
// serves on HOST (this side of the link), and Chromium runs where $CHROMIUM puts it (a wrapper
// that starts it in the phone's network namespace). The page streams Chromium's fake camera at
// 640x480 for SECONDS; prints one JSON line of the page's own figures: frame -> LightingUpdate
// latency p50/p99, frames sent, map sets, updates.
//   CHROMIUM=WRAPPER node bench/page_on_link.mjs BUILD_BIN SECONDS HOST
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';

import { launchChromium, enableOrientationOverride, overrideOrientation } from '../tests/web/harness.mjs';
import { startDaemon } from '../tests/web/phone_session.mjs';

const bin = path.resolve(process.argv[2] || 'build/bin');
const seconds = Number(process.argv[3] || 20);
const host = process.argv[4] || '127.0.0.1';
const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'arlight-page-link-'));
const daemon = await startDaemon({
  bin, dir: path.join(dir, 'daemon'), webRoot: path.join(bin, 'web'), token: 'link-token-0123456789', host,
});
let result = { failed: true };
try {
  const { browser, page } = await launchChromium();
  try {
    await enableOrientationOverride(page);
    await overrideOrientation(page, { x: 0.5, y: 0, z: 0, w: Math.sqrt(0.75) });
    await page.goto(`${daemon.url}&autostart=1&size=640x480&upload=auto`, { timeout: 60000 });
    await page.waitForFunction(() => window.arlight.status().lighting !== 'none', null, { timeout: 60000 });
    const first = await page.evaluate(() => window.arlight.status());
    await new Promise((r) => setTimeout(r, seconds * 1000));
    const last = await page.evaluate(() => window.arlight.status());
    result = {
      failed: false,
      seconds,
      frames_sent: last.frames_sent - first.frames_sent,
      updates: last.updates - first.updates,
      map_sets: last.map_sets - first.map_sets,
      latency_p50_ms: last.latency_p50_ms,
      latency_p99_ms: last.latency_p99_ms,
      // The daemon's byte advice at the end and the JPEG quality the page encoded at (issue 36 §1).
      advised_frame_bytes: last.advised_frame_bytes,
      jpeg_quality: last.jpeg_quality,
      connected: last.connected,
      last_error: last.last_error || '',
    };
  } finally {
    await browser.close();
  }
} catch (e) {
  result = { failed: true, error: String(e.message || e).slice(0, 300) };
} finally {
  await daemon.stop();
  fs.rmSync(dir, { recursive: true, force: true });
}
console.log(JSON.stringify(result));
