// The browser part of `make demo`: a simulated phone opens the page arlightd serves in headless
// Chromium, sweeps the room (arlight-sim's video as its camera, the true orientation as its
// sensor) and the page composites a sphere lit by what arlightd captured; then it walks around the
// marker on the floor, continuing the same session, and the page stands the bunny on it. Saves
// screenshots along the way, a contact sheet of them and web.json (the page's own figures), then
// prints how to connect a real phone. Then /three.html (three.js, ArlightEstimatedLight) watching
// the phone's session: screenshots in OUT_DIR/../three/.
//   node deploy/web-demo.mjs BUILD_BIN OUT_DIR PROBE
import { randomBytes } from 'node:crypto';
import fs from 'node:fs';
import path from 'node:path';

import { launchChromium } from '../tests/web/harness.mjs';
import { simulateRoom, startDaemon, playRoom } from '../tests/web/phone_session.mjs';

if (process.argv.length < 5) {
  console.error('usage: node deploy/web-demo.mjs BUILD_BIN OUT_DIR PROBE');
  process.exit(2);
}
// Absolute: Chromium reads the fake camera's file by absolute path.
const [bin, out, probe] = process.argv.slice(2, 5).map((p) => path.resolve(p));
fs.rmSync(out, { recursive: true, force: true });
fs.mkdirSync(out, { recursive: true });
const token = randomBytes(16).toString('hex');

// The phone holds still for 3 s while the page connects, so every view of the sweep is sent.
const room = simulateRoom({ bin, probe, dir: out, frames: 96, fps: 4, width: 640, height: 480, seed: 3, leadIn: 12 });
const daemon = await startDaemon({ bin, dir: path.join(out, 'daemon'), webRoot: path.join(bin, 'web'), token });
let { browser, page } = await launchChromium({ y4m: room.y4m });
const shots = [];
try {
  await page.setViewportSize({ width: 960, height: 600 });  // landscape: camera view beside the panel
  let nextShot = 0;
  await playRoom(page, daemon.url, room, {
    onTick: async (s) => {
      if (!s.camera_opened_at || Date.now() < nextShot) return;
      nextShot = Date.now() + 2000;
      const file = path.join(out, `page_${String(shots.length).padStart(2, '0')}.png`);
      await page.screenshot({ path: file });
      shots.push(file);
    },
  });
  await page.waitForFunction(() => window.arlight.status().map_sets >= 1, null, { timeout: 60000 });
  await page.waitForTimeout(1500);
  await page.screenshot({ path: path.join(out, 'page_sweep.png') });
  shots.push(path.join(out, 'page_sweep.png'));
  const status = await page.evaluate(() => window.arlight.status());
  const sweepShots = shots.length;
  await browser.close();

  // Around the marker (a second video: a new browser, so its fake camera starts at the start),
  // in the same session: the maps of the whole sweep light the bunny.
  const orbit = simulateRoom({
    bin, probe, dir: path.join(out, 'marker'), frames: 48, fps: 4, width: 640, height: 480, seed: 3,
    extraArgs: ['--trajectory', 'orbit', '--marker', '7,0.2'],
  });
  ({ browser, page } = await launchChromium({ y4m: orbit.y4m }));
  await page.setViewportSize({ width: 960, height: 600 });
  nextShot = 0;
  await playRoom(page, daemon.url, orbit, {
    fragment: `&marker=7,0.2&model=bunny&session=${status.session_id}`,
    lastFrame: 40,  // mid-orbit (the video starts again after its last frame)
    onTick: async (s) => {
      if (!s.tracked_frames || Date.now() < nextShot) return;
      // The shown frame composited again by the probe once its own pose is in (the page itself
      // shows each frame with the pose tracked in it while the marker is tracked).
      const p = await page.evaluate(() => window.arlight.probe());
      if (!p || p.media_time !== p.tracked_media_time) return;
      nextShot = Date.now() + 2000;
      const file = path.join(out, `page_${String(shots.length).padStart(2, '0')}.png`);
      await page.screenshot({ path: file });
      await page.screenshot({ path: path.join(out, 'page.jpg'), type: 'jpeg', quality: 80 });
      fs.copyFileSync(file, path.join(out, 'page.png'));
      shots.push(file);
    },
  });
  const marker = await page.evaluate(() => window.arlight.status());
  fs.writeFileSync(path.join(out, 'web.json'),
    JSON.stringify({ sweep: { ...status, sh: undefined }, marker: { ...marker, sh: undefined } }, null, 2));

  // /three.html (issue 35): three.js lighting a glTF model with the room's light, watching the
  // phone's session (its page has closed; the session lives on in arlightd), as a desktop beside
  // the phone would. The phone streamed the thesis's maps, so arlightd computes a GGX chain for
  // the watcher. Into OUT/../three/.
  const threeOut = path.join(path.dirname(out), 'three');
  fs.rmSync(threeOut, { recursive: true, force: true });
  fs.mkdirSync(threeOut, { recursive: true });
  const watched = status.session_id;
  const threePage = await (await browser.contexts())[0].newPage();
  await threePage.setViewportSize({ width: 960, height: 600 });
  const threeStatus = {};
  for (const model of ['spheres', 'bunny']) {
    await threePage.goto('about:blank');  // a new fragment alone would not load the page again
    await threePage.goto(`https://127.0.0.1:${daemon.web}/three.html#session=${watched}&device=phone&token=${token}&model=${model}`);
    await threePage.waitForFunction(() => {
      const s = window.arlightThree && window.arlightThree.status();
      return s && s.map_sets >= 1 && s.environment_face > 0 && s.model;
    }, null, { timeout: 60000 });
    await threePage.waitForTimeout(1500);  // the model loaded, the cross-fade over
    await threePage.screenshot({ path: path.join(threeOut, `${model}.png`) });
    threeStatus[model] = await threePage.evaluate(() => ({ ...window.arlightThree.status(),
      light_estimate: window.arlightThree.lightEstimate() }));
  }
  fs.writeFileSync(path.join(threeOut, 'three.json'), JSON.stringify(threeStatus, (k, v) =>
    (v instanceof Object && v.constructor && v.constructor.name === 'Float32Array' ? Array.from(v) : v), 2));
  await threePage.close();

  // The contact sheet, drawn by the browser itself (no image library needed).
  const images = [...shots.slice(0, sweepShots).slice(-6), ...shots.slice(sweepShots).slice(-6)].map((f) => `data:image/png;base64,${fs.readFileSync(f).toString('base64')}`);
  await page.setViewportSize({ width: 1440, height: 900 });
  await page.setContent('<body style="margin:0;background:#000"><canvas id="sheet"></canvas></body>');
  await page.evaluate(async (urls) => {
    const imgs = await Promise.all(urls.map((u) => new Promise((resolve) => {
      const img = new Image();
      img.onload = () => resolve(img);
      img.src = u;
    })));
    const cols = 4;
    const w = 360;
    const h = Math.round((w * imgs[0].height) / imgs[0].width);
    const sheet = document.getElementById('sheet');
    sheet.width = cols * w;
    sheet.height = Math.ceil(imgs.length / cols) * h;
    const ctx = sheet.getContext('2d');
    imgs.forEach((img, i) => ctx.drawImage(img, (i % cols) * w, Math.floor(i / cols) * h, w, h));
  }, images);
  await page.locator('#sheet').screenshot({ path: path.join(out, 'contact_sheet.png') });

  // What arlightd printed for the phone (its URL and QR code), as a terminal shows it.
  const banner = daemon.banner.replace(/&/g, '&amp;').replace(/</g, '&lt;');
  await page.setContent(`<body style="margin:0;background:#111"><pre id="term" style="display:inline-block;
    margin:0;padding:12px;color:#eee;background:#111;font:13px/13px monospace">${banner}</pre></body>`);
  await page.locator('#term').screenshot({ path: path.join(out, 'terminal.png') });
  console.log(`web demo: ${status.frames_processed} frames captured by arlightd from the page, ` +
    `${status.map_sets} map sets, coverage ${(status.coverage * 100).toFixed(0)} %, ` +
    `${status.fps.toFixed(1)} fps in headless Chromium (SwiftShader), ` +
    `latency p50 ${status.latency_p50_ms.toFixed(0)} ms; then the marker tracked in ${marker.tracked_frames} frames ` +
    `(${marker.session_id === status.session_id ? 'the same session' : 'a new session'}), ` +
    `the ${marker.model} on it`);
} finally {
  await browser.close();
  await daemon.stop();
}
console.log(`
To connect your phone: on this machine run
  ${path.join(bin, 'arlightd')} --tokens TOKENS_FILE --web 0.0.0.0:8443
(a TOKENS_FILE line: "phone <a-long-random-token>"), then scan the QR code it prints with the
phone's camera, accept the self-signed certificate once, tap Start and sweep the room.`);
