// Self-test of tests/web/harness.mjs against the real headless Chromium, and of
// client/web/src/camera.js in it. Run from the repository root:
//   node --test tests/web/harness.test.mjs
// Needs client/web/node_modules (`npm ci` in client/web) and Chromium (/usr/bin/chromium or
// $CHROMIUM). The page is served over HTTPS with a throwaway self-signed certificate (openssl),
// or over http://localhost (also a secure context) where openssl is missing.

import test, { after, before } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import http from 'node:http';
import https from 'node:https';
import os from 'node:os';
import path from 'node:path';

import {
  WEB_ROOT,
  chromiumRoundedQuaternion,
  launchChromium,
  overrideDeviceOrientation,
  overrideOrientation,
  overrideRelativeOrientation,
  solidFrame,
  writeY4M,
} from './harness.mjs';

const SRC_DIR = path.join(WEB_ROOT, 'src');
const RED = [200, 40, 40];
const COLOUR_TOL = 12;
const QUAT_TOL = 1e-6;
const W = 320;
const H = 240;

// The page: opens the camera with camera.js, grabs frames, runs orientation sensors.
const PAGE = `<!doctype html>
<meta charset="utf-8">
<title>arlight harness self-test</title>
<link rel="icon" href="data:,">
<script type="module">
import { openCamera, FrameGrabber } from '/src/camera.js';

window.grabFrame = async () => {
  const cam = await openCamera({ width: 640, height: 480 });
  try {
    const grabber = new FrameGrabber(cam.video);
    // Wait for three new camera frames through onFrame (requestVideoFrameCallback here).
    const times = [];
    await new Promise((resolve) => {
      const stop = grabber.onFrame((info) => {
        times.push(info.mediaTime);
        if (times.length === 3) { stop(); resolve(); }
      });
    });
    const px = grabber.rgba();
    const sum = [0, 0, 0, 0];
    for (let i = 0; i < px.length; i += 4) {
      for (let c = 0; c < 4; c++) sum[c] += px[i + c];
    }
    const n = px.length / 4;
    const jpeg = await grabber.jpeg(0.85, { redraw: false });
    const lock = await cam.lockExposure();
    return {
      width: cam.width,
      height: cam.height,
      grabberSize: [grabber.width, grabber.height],
      rgbaLength: px.length,
      rgbaType: px.constructor.name,
      mean: sum.map((s) => s / n),
      jpegLength: jpeg.length,
      jpegHead: [jpeg[0], jpeg[1]],
      jpegTail: [jpeg[jpeg.length - 2], jpeg[jpeg.length - 1]],
      frameTimes: times,
      lock,
      liveBeforeClose: cam.track.readyState,
    };
  } finally {
    cam.close();
  }
};

window.openCameraError = async (stubName) => {
  const md = navigator.mediaDevices;
  const real = md && md.getUserMedia;
  if (stubName) {
    md.getUserMedia = () => Promise.reject(new DOMException('stubbed', stubName));
  }
  try {
    const cam = await openCamera();
    cam.close();
    return null;
  } catch (e) {
    return { name: e.name, code: e.code, message: e.message, cause: e.cause ? e.cause.name : null };
  } finally {
    if (stubName) md.getUserMedia = real;
  }
};

window.slowConsumer = async () => {
  const cam = await openCamera();
  try {
    const grabber = new FrameGrabber(cam.video);
    const calls = [];
    let running = 0;
    let maxRunning = 0;
    await new Promise((resolve) => {
      const stop = grabber.onFrame(async (info) => {
        running += 1;
        maxRunning = Math.max(maxRunning, running);
        calls.push({ presented: info.presentedFrames, dropped: info.dropped, t: info.mediaTime });
        await new Promise((r) => setTimeout(r, 150)); // ~4 frames at 30 fps
        running -= 1;
        if (calls.length === 4) { stop(); resolve(); }
      });
    });
    return { calls, maxRunning };
  } finally {
    cam.close();
  }
};

window.lockedExposure = async () => {
  const cam = await openCamera();
  try {
    return { caps: cam.capabilities.exposureMode || null, lock: await cam.lockExposure(),
      mode: cam.track.getSettings().exposureMode };
  } finally {
    cam.close();
  }
};

window.orientationEvents = [];
const onDeviceOrientation = (e) => orientationEvents.push([e.alpha, e.beta, e.gamma]);
window.listenDeviceOrientation = (on) => {
  if (on) window.addEventListener('deviceorientation', onDeviceOrientation);
  else window.removeEventListener('deviceorientation', onDeviceOrientation);
};

window.sensorReadings = { abs: [], rel: [] };
window.sensorErrors = [];
window.startSensor = (kind) => {
  const Sensor = kind === 'abs' ? AbsoluteOrientationSensor : RelativeOrientationSensor;
  const s = new Sensor({ frequency: 30 });
  s.onreading = () => sensorReadings[kind].push(Array.from(s.quaternion));
  s.onerror = (e) => sensorErrors.push(kind + ': ' + e.error.name + ': ' + e.error.message);
  s.start();
};
</script>
`;

const MIME = { '.js': 'text/javascript', '.mjs': 'text/javascript', '.json': 'application/json' };

/** Serves PAGE at / and client/web/src at /src/. */
function handler(req, res) {
  const url = new URL(req.url, 'https://localhost');
  if (url.pathname === '/') {
    res.writeHead(200, { 'content-type': 'text/html; charset=utf-8', 'cache-control': 'no-store' });
    res.end(PAGE);
    return;
  }
  if (url.pathname.startsWith('/src/')) {
    const file = path.resolve(SRC_DIR, '.' + url.pathname.slice('/src'.length));
    if (file.startsWith(SRC_DIR + path.sep) && fs.existsSync(file) && fs.statSync(file).isFile()) {
      res.writeHead(200, {
        'content-type': MIME[path.extname(file)] || 'application/octet-stream',
        'cache-control': 'no-store',
      });
      res.end(fs.readFileSync(file));
      return;
    }
  }
  res.writeHead(404, { 'content-type': 'text/plain' });
  res.end('not found');
}

/** A self-signed certificate for localhost in dir, or null without openssl. */
function makeCert(dir) {
  const key = path.join(dir, 'key.pem');
  const cert = path.join(dir, 'cert.pem');
  try {
    execFileSync('openssl', [
      'req', '-x509', '-newkey', 'ec', '-pkeyopt', 'ec_paramgen_curve:prime256v1', '-nodes',
      '-keyout', key, '-out', cert, '-days', '1', '-subj', '/CN=localhost',
      '-addext', 'subjectAltName=DNS:localhost,IP:127.0.0.1',
    ], { stdio: 'pipe' });
  } catch (e) {
    if (e.code === 'ENOENT') return null;
    throw e;
  }
  return { key: fs.readFileSync(key), cert: fs.readFileSync(cert) };
}

let tmp;
let server;
let plainServer;
let origin;
let insecureOrigin;
let browser;
let page;
const pageErrors = [];

before(async () => {
  tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'arlight-harness-'));
  const tls = makeCert(tmp);
  server = tls ? https.createServer(tls, handler) : http.createServer(handler);
  await new Promise((resolve) => server.listen(0, '127.0.0.1', resolve));
  origin = `${tls ? 'https' : 'http'}://localhost:${server.address().port}`;
  // Plain http under a name that is not localhost: not a secure context.
  plainServer = http.createServer(handler);
  await new Promise((resolve) => plainServer.listen(0, '127.0.0.1', resolve));
  insecureOrigin = `http://arlight.test:${plainServer.address().port}`;

  const y4m = path.join(tmp, 'red.y4m');
  writeY4M(y4m, W, H, [solidFrame(W, H, RED)], 30);

  ({ browser, page } = await launchChromium({
    y4m,
    extraArgs: ['--host-resolver-rules=MAP arlight.test 127.0.0.1'],
  }));
  page.on('pageerror', (e) => pageErrors.push(String(e)));
  page.on('console', (m) => {
    if (m.type() === 'error') pageErrors.push(m.text());
  });
  // Enabled before the page exists: the override must be on before the page starts a sensor.
  // (It survives navigation.)
  await overrideOrientation(page, { x: 0, y: 0, z: 0, w: 1 }, { type: 'both' });
  await page.goto(`${origin}/`);
});

after(async () => {
  if (browser) await browser.close();
  if (server) await new Promise((resolve) => server.close(resolve));
  if (plainServer) await new Promise((resolve) => plainServer.close(resolve));
  if (tmp) fs.rmSync(tmp, { recursive: true, force: true });
});

test('writeY4M writes the header and frame layout Chromium reads', () => {
  const file = path.join(tmp, 'layout.y4m');
  const frames = [solidFrame(4, 2, [255, 255, 255]), solidFrame(4, 2, [0, 0, 0])];
  const { header, frameBytes, bytes } = writeY4M(file, 4, 2, frames, 25);
  assert.equal(header, 'YUV4MPEG2 W4 H2 F25:1 Ip A1:1 C420jpeg XCOLORRANGE=LIMITED\n');
  assert.equal(frameBytes, 4 * 2 + 2 * 2 * 1);
  const data = fs.readFileSync(file);
  assert.equal(data.length, bytes);
  assert.equal(data.subarray(0, header.length).toString('latin1'), header);
  const f0 = header.length;
  assert.equal(data.subarray(f0, f0 + 6).toString('latin1'), 'FRAME\n');
  // White → Y 235, Cb = Cr = 128; black → Y 16.
  assert.deepEqual([...data.subarray(f0 + 6, f0 + 6 + 12)], [235, 235, 235, 235, 235, 235, 235, 235, 128, 128, 128, 128]);
  const f1 = f0 + 6 + frameBytes;
  assert.equal(data.subarray(f1, f1 + 6).toString('latin1'), 'FRAME\n');
  assert.deepEqual([...data.subarray(f1 + 6, f1 + 6 + 8)], Array(8).fill(16));
  assert.throws(() => writeY4M(file, 3, 2, [new Uint8Array(18)], 30), RangeError);
  assert.throws(() => writeY4M(file, 4, 2, [new Uint8Array(5)], 30), RangeError);
  assert.throws(() => writeY4M(file, 4, 2, frames, 29.97), RangeError);
});

test('the page is a secure context served by the test server', async () => {
  const info = await page.evaluate(() => ({
    secure: window.isSecureContext,
    protocol: location.protocol,
    hasSensor: typeof AbsoluteOrientationSensor,
  }));
  assert.equal(info.secure, true);
  assert.equal(info.protocol, origin.startsWith('https') ? 'https:' : 'http:');
  assert.equal(info.hasSensor, 'function');
});

test('camera.js grabs the fake camera\'s Y4M frame: colour, size, JPEG', async () => {
  const r = await page.evaluate(() => window.grabFrame());
  assert.deepEqual([r.width, r.height], [W, H], 'track settings size');
  assert.deepEqual(r.grabberSize, [W, H], 'grabber size');
  assert.equal(r.rgbaLength, W * H * 4);
  assert.equal(r.rgbaType, 'Uint8ClampedArray');
  for (let c = 0; c < 3; c++) {
    assert.ok(
      Math.abs(r.mean[c] - RED[c]) <= COLOUR_TOL,
      `mean colour [${r.mean.map((v) => v.toFixed(1)).join(', ')}] is not within ±${COLOUR_TOL} of [${RED}]`,
    );
  }
  assert.equal(r.mean[3], 255, 'opaque');
  assert.deepEqual(r.jpegHead, [0xff, 0xd8], 'JPEG SOI');
  assert.deepEqual(r.jpegTail, [0xff, 0xd9], 'JPEG EOI');
  assert.ok(r.jpegLength > 100, `JPEG of ${r.jpegLength} bytes`);
  assert.equal(r.frameTimes.length, 3);
  assert.ok(r.frameTimes[0] < r.frameTimes[1] && r.frameTimes[1] < r.frameTimes[2],
    `onFrame mediaTimes must increase: ${r.frameTimes}`);
  // The Y4M fake camera has no exposure controls: the lock reports failure, with a reason.
  assert.equal(r.lock.locked, false);
  assert.equal(r.lock.exposureTime, null);
  assert.match(r.lock.reason, /exposure stays automatic/);
  assert.equal(r.liveBeforeClose, 'live');
  assert.deepEqual(pageErrors, []);
});

/** Waits until the page's sensor of `kind` has a reading other than `previous`. */
async function nextReading(kind, previous) {
  const handle = await page.waitForFunction(
    ([k, prev]) => {
      const list = window.sensorReadings[k];
      const last = list[list.length - 1];
      if (!last || (prev && last.every((v, i) => v === prev[i]))) return null;
      return last;
    },
    [kind, previous],
    { timeout: 5000, polling: 20 },
  );
  return handle.jsonValue();
}

function assertQuatClose(actual, expected, what, tol = QUAT_TOL) {
  const want = [expected.x, expected.y, expected.z, expected.w];
  assert.equal(actual.length, 4, what);
  for (let i = 0; i < 4; i++) {
    assert.ok(Math.abs(actual[i] - want[i]) <= tol,
      `${what}: got [${actual.join(', ')}], expected [${want.join(', ')}] (±${tol})`);
  }
}

function unit(q) {
  const n = Math.hypot(q.x, q.y, q.z, q.w);
  return { x: q.x / n, y: q.y / n, z: q.z / n, w: q.w / n };
}

test('AbsoluteOrientationSensor follows Emulation.setSensorOverrideReadings', async () => {
  await page.evaluate(() => window.startSensor('abs'));
  const identity = await nextReading('abs', null);
  assertQuatClose(identity, { x: 0, y: 0, z: 0, w: 1 }, 'initial override');

  // An arbitrary rotation: the page reads Chromium's privacy-rounded value.
  const q1 = { x: 0.1, y: 0.2, z: 0.3, w: Math.sqrt(1 - 0.14) };
  const expected1 = await overrideOrientation(page, q1);
  const r1 = await nextReading('abs', identity);
  assertQuatClose(r1, expected1, 'q1 (rounded)');
  assertQuatClose(r1, q1, 'q1 within the 0.1° privacy rounding', 2e-3);
  assert.ok(Math.abs(r1[0] - q1.x) > QUAT_TOL, 'q1 really is rounded (else the port is untested)');

  // 90° about the device x axis, unnormalised on input: whole tenths of a degree round exactly.
  const q2 = { x: 2 * Math.SQRT1_2, y: 0, z: 0, w: 2 * Math.SQRT1_2 };
  const expected2 = await overrideOrientation(page, q2);
  const r2 = await nextReading('abs', r1);
  assertQuatClose(r2, unit(q2), 'q2');
  assertQuatClose(r2, expected2, 'q2 (rounded)');
  assert.deepEqual(await page.evaluate(() => window.sensorErrors), []);
});

test('RelativeOrientationSensor follows its own override', async () => {
  await page.evaluate(() => window.startSensor('rel'));
  const first = await nextReading('rel', null);
  assertQuatClose(first, { x: 0, y: 0, z: 0, w: 1 }, 'initial relative override');
  const q = { x: 0, y: -Math.sin(Math.PI / 6), z: 0, w: Math.cos(Math.PI / 6) }; // −60° about y
  const expected = await overrideRelativeOrientation(page, q);
  const r = await nextReading('rel', first);
  assertQuatClose(r, expected, 'relative (rounded)');
  assertQuatClose(r, q, 'relative');
  // The absolute sensor keeps its own reading.
  const abs = await page.evaluate(() => window.sensorReadings.abs.at(-1));
  assertQuatClose(abs, unit({ x: 1, y: 0, z: 0, w: 1 }), 'absolute unchanged');
  assert.deepEqual(await page.evaluate(() => window.sensorErrors), []);
});

/** Opens the test page in a fresh page (its own CDP session and overrides). */
async function freshPage(setup) {
  const p = await page.context().newPage();
  await setup(p);
  await p.goto(`${origin}/`);
  await p.evaluate(() => window.listenDeviceOrientation(true));
  return p;
}

/** Waits for a deviceorientation event with non-null angles. */
async function deviceOrientationEvent(p) {
  const handle = await p.waitForFunction(
    () => window.orientationEvents.find((e) => e[0] !== null) || null,
    null, { timeout: 5000, polling: 20 },
  );
  return handle.jsonValue();
}

test('deviceorientation follows the relative-orientation override (Euler angles)', async () => {
  // 30° about the device z axis (ENU up when flat): alpha 30, beta 0, gamma 0.
  const q = { x: 0, y: 0, z: Math.sin(Math.PI / 12), w: Math.cos(Math.PI / 12) };
  const p = await freshPage((fresh) => overrideRelativeOrientation(fresh, q));
  try {
    const ev = await deviceOrientationEvent(p);
    assert.ok(Math.abs(ev[0] - 30) < 1e-9 && Math.abs(ev[1]) < 1e-9 && Math.abs(ev[2]) < 1e-9,
      `deviceorientation [${ev}] for 30° about z`);
  } finally {
    await p.close();
  }
});

test('deviceorientation follows DeviceOrientation.setDeviceOrientationOverride (0.1° rounding)', async () => {
  const p = await freshPage((fresh) =>
    overrideDeviceOrientation(fresh, { alpha: 30.25, beta: 45, gamma: -20.04 }));
  try {
    const ev = await deviceOrientationEvent(p);
    const want = [30.25, 45, -20.04];
    for (let i = 0; i < 3; i++) {
      assert.ok(Math.abs(ev[i] - want[i]) <= 0.1 + 1e-9, `deviceorientation [${ev}] vs [${want}]`);
    }
    // The harness refuses to mix it with the Emulation overrides on one page.
    await assert.rejects(overrideRelativeOrientation(p, { x: 0, y: 0, z: 0, w: 1 }), /fresh page/);
  } finally {
    await p.close();
  }
  // … and the other way round.
  await assert.rejects(overrideDeviceOrientation(page, { alpha: 0, beta: 0, gamma: 0 }), /fresh page/);
});

test('FrameGrabber.onFrame: newest frame wins behind a slow async consumer', async () => {
  const { calls, maxRunning } = await page.evaluate(() => window.slowConsumer());
  assert.equal(maxRunning, 1, 'callbacks never overlap');
  assert.equal(calls.length, 4);
  for (let i = 1; i < calls.length; i++) {
    assert.ok(calls[i].t > calls[i - 1].t, `mediaTime increases: ${JSON.stringify(calls)}`);
    // Frames that arrived while the callback ran were skipped, and counted.
    assert.ok(calls[i].dropped >= 1, `dropped frames reported: ${JSON.stringify(calls)}`);
    assert.equal(calls[i].presented - calls[i - 1].presented - 1, calls[i].dropped,
      `dropped = gap in presentedFrames: ${JSON.stringify(calls)}`);
  }
});

test('openCamera names its errors: insecure context, refused, absent, busy', async () => {
  // Real: plain http to a non-localhost name.
  const other = await page.context().newPage();
  try {
    await other.goto(`${insecureOrigin}/`);
    assert.equal(await other.evaluate(() => window.isSecureContext), false);
    const e = await other.evaluate(() => window.openCameraError(null));
    assert.equal(e && e.name, 'InsecureContextError', JSON.stringify(e));
    assert.equal(e.code, 'insecure-context');
  } finally {
    await other.close();
  }
  // getUserMedia's rejections (stubbed: the fake UI always accepts and the fake device exists).
  const cases = [
    ['NotAllowedError', 'CameraPermissionError', 'permission-denied'],
    ['NotFoundError', 'CameraNotFoundError', 'not-found'],
    ['OverconstrainedError', 'CameraNotFoundError', 'not-found'],
    ['NotReadableError', 'CameraBusyError', 'busy'],
    ['TypeError', 'CameraError', 'failed'],
  ];
  for (const [domName, name, code] of cases) {
    const e = await page.evaluate((n) => window.openCameraError(n), domName);
    assert.deepEqual(e && [e.name, e.code, e.cause], [name, code, domName], JSON.stringify(e));
    assert.match(e.message, new RegExp(domName));
  }
  // And the real camera still opens afterwards.
  assert.equal(await page.evaluate(() => window.openCameraError(null)), null);
});

test('lockExposure locks manual exposure on a camera that has it (Chromium\'s built-in fake)', async () => {
  const second = await launchChromium({ y4m: null });
  try {
    await second.page.goto(`${origin}/`);
    const r = await second.page.evaluate(() => window.lockedExposure());
    assert.ok(Array.isArray(r.caps) && r.caps.includes('manual'), JSON.stringify(r));
    assert.equal(r.lock.locked, true, JSON.stringify(r.lock));
    assert.equal(r.mode, 'manual');
    assert.equal(r.lock.reason, 'exposureMode manual');
    // Chromium's fake camera: exposureTime 10…100 in 100 µs units → 1…10 ms.
    assert.ok(r.lock.exposureTime >= 0.001 && r.lock.exposureTime <= 0.01,
      `exposureTime ${r.lock.exposureTime} s`);
  } finally {
    await second.browser.close();
  }
});

test('chromiumRoundedQuaternion matches Chromium\'s own unit test values', () => {
  // services/device/generic_sensor/platform_sensor_util_unittest.cc, RoundQuaternion.
  const r = chromiumRoundedQuaternion({ x: 0.408333, y: -0.694318, z: -0.107955, w: 0.582693 });
  assertQuatClose([r.x, r.y, r.z, r.w],
    { x: 0.40879894045956067, y: -0.69400288443777802, z: -0.10747054463443845, w: 0.58283231268278346 },
    'Chromium RoundQuaternion', 1e-15);
  assert.deepEqual(chromiumRoundedQuaternion({ x: 0.408333, y: -0.694318, z: -0.107955, w: 1 }),
    { x: 0, y: 0, z: 0, w: 1 });
});
