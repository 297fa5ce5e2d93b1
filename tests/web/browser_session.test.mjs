// A phone-shaped session end to end in a real headless Chromium (SwiftShader's WebGL2): the page
// arlightd serves, its WebAssembly build of the project's C++, a fake camera playing what
// arlight-sim rendered of a room (a Y4M), the orientation sensor fed through the DevTools
// protocol from the same trajectory in step with the video, and a real arlightd over wss on
// loopback. Run by ctest (tests/web/web_tests.cmake sets ARLIGHT_BIN and ARLIGHT_SOURCE_DIR).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { spawn, execFileSync } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';

import { launchChromium, enableOrientationOverride, overrideOrientation } from './harness.mjs';
import { sensorQuaternionFromCameraQuat } from '../../client/web/src/orientation.js';

const BIN = process.env.ARLIGHT_BIN;
const SOURCE = process.env.ARLIGHT_SOURCE_DIR;
const TOKEN = 'web-test-token-0123456789';

// The simulated phone: a sweep of the room at 4 frames a second, so that the sensor override
// (set 100 ms before each frame is due) is always the one of the frame the page receives.
const FRAMES = 96;
const FPS = 4;
const WIDTH = 320;
const HEIGHT = 240;
const HFOV_DEG = 60;  // arlight-sim's default
const LEAD_MS = 100;

async function startDaemon(dir, webRoot) {
  fs.mkdirSync(dir, { recursive: true });
  fs.writeFileSync(path.join(dir, 'tokens'), `phone ${TOKEN}\n`);
  const daemon = spawn(path.join(BIN, 'arlightd'), [
    '--listen', '127.0.0.1:0', '--admin', '127.0.0.1:0', '--web', '127.0.0.1:0',
    '--web-root', webRoot, '--data-dir', path.join(dir, 'data'),
    '--tokens', path.join(dir, 'tokens'), '--idle-timeout', '600',
  ], { stdio: ['ignore', 'pipe', 'pipe'] });
  let out = '';
  let err = '';
  daemon.stderr.on('data', (d) => { err += d; });
  const ready = await new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error(`arlightd did not start: ${out}${err}`)), 20000);
    daemon.stdout.on('data', (d) => {
      out += d;
      const url = /phone page (\S+)/.exec(out);
      const ports = /listening on 127\.0\.0\.1:(\d+), admin on (\d+), web on (\d+)/.exec(out);
      if (url && ports) {
        clearTimeout(timer);
        resolve({ url: url[1], web: Number(ports[3]) });
      }
    });
    daemon.on('exit', (code) => reject(new Error(`arlightd exited (${code}): ${out}${err}`)));
  });
  return { daemon, ...ready, log: () => err };
}

// Relative RMS difference of the irradiance two SH sets (bands 0-2, RGB) describe: by Parseval,
// the norm of the clamped-cosine-weighted coefficient differences (A0 = pi, A1 = 2pi/3,
// A2 = pi/4) over the norm of the reference's; independent of the basis' sign conventions.
function irradianceRelativeRms(test, reference) {
  const a = (k) => (k === 0 ? Math.PI : k < 4 ? (2 * Math.PI) / 3 : Math.PI / 4);
  let num = 0;
  let den = 0;
  for (let k = 0; k < 9; ++k) {
    for (let c = 0; c < 3; ++c) {
      const r = reference[k][c];
      num += (a(k) * (test[3 * k + c] - r)) ** 2;
      den += (a(k) * r) ** 2;
    }
  }
  return Math.sqrt(num / den);
}

test('a phone-shaped session captures the room, gets lighting and renders the object', { timeout: 300000 }, async () => {
  assert.ok(BIN && SOURCE, 'ARLIGHT_BIN and ARLIGHT_SOURCE_DIR must be set (ctest does)');
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'arlight-web-session-'));
  const rec = path.join(dir, 'rec');
  const y4m = path.join(dir, 'camera.y4m');
  execFileSync(path.join(BIN, 'arlight-sim'), [
    '--env', path.join(SOURCE, 'data/probes/venice.exr'), '--out', rec, '--frames', String(FRAMES),
    '--fps', String(FPS), '--size', `${WIDTH}x${HEIGHT}`, '--gyro-drift', '0', '--seed', '11',
    '--y4m', y4m,
  ], { stdio: 'pipe' });
  const poses = JSON.parse(fs.readFileSync(path.join(rec, 'truth', 'truth.json'))).poses;
  const recording = JSON.parse(fs.readFileSync(path.join(rec, 'recording.json')));
  // The browser cannot report its exposure: arlightd assumes 1/60 s at gain 1, so its map is the
  // room's radiance scaled by the exposure the video was really taken at over that.
  const exposure = recording.frames[0].exposure * recording.frames[0].gain;
  const scale = exposure / (1 / 60);
  execFileSync(path.join(BIN, 'arlight-maps'), [
    'sh', '--input', path.join(rec, 'truth', 'env.exr'), '--order', '3', '--size', '256',
    '--out', path.join(dir, 'sh'),
  ], { stdio: 'pipe' });
  const truthSh = JSON.parse(fs.readFileSync(path.join(dir, 'sh', 'sh.json'))).coefficients
    .map((rgb) => rgb.map((v) => v * scale));

  const d = await startDaemon(path.join(dir, 'daemon'), path.join(BIN, 'web'));
  const { browser, context, page } = await launchChromium({ y4m });
  try {
    const pageErrors = [];
    page.on('pageerror', (e) => pageErrors.push(e.message));
    const sensorFor = (i) => {
      const o = poses[Math.min(FRAMES - 1, i)].orientation;  // [w, x, y, z], camera -> world
      const [x, y, z, w] = sensorQuaternionFromCameraQuat(o, 0);
      return { x, y, z, w };
    };
    await enableOrientationOverride(page);
    await overrideOrientation(page, sensorFor(0));
    const vfov = (2 * Math.atan(Math.tan((HFOV_DEG * Math.PI) / 360) * (HEIGHT / WIDTH)) * 180) / Math.PI;
    await page.goto(`${d.url}&autostart=1&fov=${vfov}`);

    // Pace the sensor with the video. Chromium's fake camera shows frame i from (i - 1) / FPS
    // after getUserMedia resolves (measured: pacing for i / FPS put every frame's orientation one
    // frame behind, and the captured irradiance 5.7 % off instead of 2 %, at 2 and at 4 fps).
    const probes = [];
    let status = null;
    let lastIndex = 0;
    const deadline = Date.now() + 150000;
    while (Date.now() < deadline) {
      status = await page.evaluate(() => window.arlight.status());
      if (status.camera_opened_at) {
        const i = Math.floor(((Date.now() - status.camera_opened_at + LEAD_MS) / 1000) * FPS) + 1;
        if (i >= FRAMES) break;  // one pass of the video
        if (i !== lastIndex) {
          await overrideOrientation(page, sensorFor(i));
          lastIndex = i;
        }
      }
      if (status.lighting !== 'none' && probes.length < 200) {
        const p = await page.evaluate(() => window.arlight.probe());
        if (p) probes.push(p);
      }
      await new Promise((r) => setTimeout(r, 20));
    }
    // Let the last frames and a map set of the whole sweep arrive.
    await page.waitForFunction(() => {
      const s = window.arlight.status();
      return s.updates >= s.frames_sent - 1 && s.map_sets >= 1;
    }, null, { timeout: 60000 });
    status = await page.evaluate(() => window.arlight.status());

    assert.deepEqual(pageErrors, []);
    assert.equal(status.connected, true);
    assert.equal(status.orientation, 'absolute-orientation-sensor');
    assert.ok(status.frames_sent >= FRAMES * 0.6, `only ${status.frames_sent} of ${FRAMES} frames sent`);
    assert.ok(status.frames_processed >= status.frames_sent * 0.9,
      `${status.frames_processed} of ${status.frames_sent} frames processed`);
    assert.ok(status.map_sets >= 1);
    assert.equal(status.lighting, 'maps');
    assert.ok(status.coverage > 0.9, `coverage ${status.coverage}`);
    assert.equal(status.last_error, '');
    // The room's irradiance as the session captured it, against the simulator's truth.
    const dc = status.sh[1] / truthSh[0][1];
    if (process.env.ARLIGHT_WEB_DEBUG) console.log(JSON.stringify({ sh: status.sh.map((v) => +v.toFixed(3)), truth: truthSh.map((c) => c.map((v) => +v.toFixed(3))) }));
    const rms = irradianceRelativeRms(status.sh, truthSh);
    console.log(`irradiance: mean ${((dc - 1) * 100).toFixed(1)} % off, relative RMS ${(rms * 100).toFixed(1)} %; ` +
      `${status.frames_processed} frames, coverage ${(status.coverage * 100).toFixed(0)} %, ` +
      `${status.fps.toFixed(1)} fps, render ${status.render_ms.toFixed(1)} ms, ` +
      `latency p50 ${status.latency_p50_ms.toFixed(0)} ms p99 ${status.latency_p99_ms.toFixed(0)} ms`);
    assert.ok(Math.abs(dc - 1) < 0.05, `mean irradiance ${((dc - 1) * 100).toFixed(1)} % off the truth`);
    assert.ok(rms < 0.05, `irradiance ${(rms * 100).toFixed(1)} % (relative RMS) off the truth`);

    // The composite: the object where the renderer put it, the camera's pixels elsewhere.
    const inside = probes.filter((p) => p.centre[0] > 20 && p.centre[0] < WIDTH - 20 &&
      p.centre[1] > 20 && p.centre[1] < HEIGHT - 20);
    assert.ok(inside.length > 0, `the object was never in view (${probes.length} probes)`);
    const diff = (a, b) => a.reduce((s, v, k) => s + Math.abs(v - b[k]), 0);
    for (const p of probes)
      assert.ok(diff(p.at_corner.composite, p.at_corner.frame) <= 3, `corner ${JSON.stringify(p.at_corner)}`);
    assert.ok(inside.some((p) => diff(p.at_object.composite, p.at_object.frame) > 30),
      `the object's pixels look like the camera's: ${JSON.stringify(inside.slice(0, 3))}`);
    await page.screenshot({ path: path.join(dir, 'page.png') });

    // A wrong token: the page says it was refused, and does not retry.
    const wrong = await context.newPage();
    await enableOrientationOverride(wrong);
    await overrideOrientation(wrong, sensorFor(0));
    await wrong.goto(d.url.replace(/token=[^&]*/, 'token=not-the-token') + '&autostart=1');
    await wrong.waitForFunction(() => /Unauthorized/.test(window.arlight.status().last_error), null,
      { timeout: 20000 });
    assert.match(await wrong.textContent('#error'), /refused: Unauthorized/);
    assert.equal((await wrong.evaluate(() => window.arlight.status())).connected, false);
  } finally {
    await browser.close();
    d.daemon.kill('SIGKILL');
  }
  fs.rmSync(dir, { recursive: true, force: true });
});
