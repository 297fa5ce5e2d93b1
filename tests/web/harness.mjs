/**
 * @file Browser test harness: headless Chromium driven by playwright-core over CDP, with a fake
 * camera fed from a Y4M file and overridable orientation sensors.
 *
 * Used by the browser tests that ctest runs as `node tests/web/<test>.mjs`. playwright-core is a
 * devDependency of client/web (run `npm ci` in client/web once); the browser is the system's
 * Chromium (`/usr/bin/chromium`, or `$CHROMIUM`), not a Playwright download.
 *
 * ## Orientation overrides (verified with Chromium 156.0.8078.114 headless, playwright-core 1.65.1)
 *
 * - `Emulation.setSensorOverrideEnabled({enabled: true, type: 'absolute-orientation'})` and then
 *   `Emulation.setSensorOverrideReadings({type: 'absolute-orientation',
 *   reading: {quaternion: {x, y, z, w}}})` drive `AbsoluteOrientationSensor`; the same with
 *   `'relative-orientation'` drives `RelativeOrientationSensor`. Both work headless.
 * - The override must be enabled **before the page starts its sensor**: a sensor started
 *   earlier fails with `NotReadableError: Could not connect to a sensor` (headless Linux has no
 *   real one). Readings may be set before or after the start; each new reading reaches the page
 *   (~100 ms later at `frequency: 30`).
 * - The page reads the quaternion **rounded for privacy** (Chromium's
 *   RoundOrientationQuaternionReading: rotation angle, and the axis' azimuth and elevation, each to
 *   a multiple of 0.1°), so it differs from what was sent by up to ~1e-3 per component:
 *   {@link chromiumRoundedQuaternion} reproduces it bit for bit. Quaternions whose rotation angle
 *   and axis angles are multiples of 0.1° (e.g. 90° turns about a coordinate axis) come through
 *   unchanged.
 * - The reading is not normalised by Chromium (a non-unit quaternion reads back as NaN), so
 *   {@link overrideOrientation} normalises; the sign of w is kept (q and −q are the same rotation).
 * - Secure context required: the Generic Sensor classes exist only in secure contexts
 *   (`https://…`, `http://localhost`, `http://127.0.0.1`); on plain http to any other host
 *   `AbsoluteOrientationSensor` is undefined and no `deviceorientation` events fire.
 * - Sensor permissions (accelerometer, gyroscope, magnetometer) read `granted` in a fresh
 *   Playwright context; {@link launchChromium} grants them explicitly anyway.
 * - `deviceorientation` events follow the `'relative-orientation'` override and
 *   `deviceorientationabsolute` follows `'absolute-orientation'`, as Euler angles rounded to
 *   0.1° (the listener must be added after the override is enabled, else it gets nulls).
 *   With only 'absolute-orientation' enabled, `deviceorientation` falls back to it (and says
 *   `absolute: true`); with only 'relative-orientation', `deviceorientationabsolute` fires once
 *   with nulls.
 * - The older `DeviceOrientation.setDeviceOrientationOverride({alpha, beta, gamma})` works on a
 *   page with no Emulation orientation override: `deviceorientation` reads the angles to within
 *   0.1°, not exactly (they pass through the quaternion and Euler privacy rounding: alpha 30.25
 *   read 30.200000000000003 with gamma −20 and 30.3 with gamma −20.04; whole degrees such as
 *   30, 45, −20 read back exactly), and RelativeOrientationSensor follows too
 *   (AbsoluteOrientationSensor and `deviceorientationabsolute` do not). It is built on the
 *   relative-orientation virtual sensor: while `Emulation.setSensorOverrideEnabled` holds 'relative-orientation' it is refused
 *   ("The 'relative-orientation' sensor type is already overridden, possibly by the Emulation
 *   domain"), and handing the sensor from one mechanism to the other (disable, clear) left
 *   listeners with null angles or no events at all, depending on which sensors the page had
 *   running. So the harness refuses to mix them on one page
 *   ({@link overrideDeviceOrientation} / {@link enableOrientationOverride} throw): use a fresh
 *   page (`context.newPage()`) per mechanism.
 *
 * ## The fake camera's Y4M file (Chromium's media/capture/video/file_video_capture_device.cc)
 *
 * `--use-fake-device-for-media-stream --use-file-for-fake-video-capture=/abs/path.y4m`. From
 * that source (the parts marked † were also tried): the file name must end in `y4m` (or
 * `mjpeg`); the header is everything before the first `FRAME` within the first 200 bytes; its
 * space-separated tags are read up to the first newline: `W<width>` `H<height>` †,
 * `F<num>:<den>` † (frame rate = the integer division num/den), `I<p|t|b>` (`Im` aborts),
 * `A<n>:<d>` (ignored), `C<420|420jpeg|420mpeg2|420paldv>` (anything else fails a CHECK; no C
 * tag means 4:2:0) †C420jpeg, and unknown tags such as ffmpeg's `XCOLORRANGE=` are skipped †.
 * Each frame must be exactly `FRAME\n` (no frame parameters: the parser skips a fixed 6 bytes)
 * followed by the Y, U, V planes (I420); the file loops at its end. The track reports the file's
 * size whatever size getUserMedia asked for (320×240 file, ideal 640×480 → 320×240) †. The exact
 * header {@link writeY4M} writes, which Chromium 156 plays †:
 *
 *     YUV4MPEG2 W<w> H<h> F<fps>:1 Ip A1:1 C420jpeg XCOLORRANGE=LIMITED\n
 *
 * Chromium 156 decodes the samples as **BT.709 limited range** (Y 16…235, Cb/Cr 16…240) into
 * the sRGB canvas (tried with C420jpeg), which is what {@link writeY4M} writes and
 * {@link rgbToYCbCr709Limited} computes. Measured: greys 0, 16, 128, 240, 255 come back exact
 * (so limited range, not full), and saturated colours within ±1 with the BT.709 matrix, while
 * BT.601-encoded ones come back off by up to 25 (200,40,40 → 213,55,37). The harness self-test
 * checks the round trip.
 */

import fs from 'node:fs';
import path from 'node:path';
import { createRequire } from 'node:module';
import { fileURLToPath } from 'node:url';

const HERE = path.dirname(fileURLToPath(import.meta.url));

/** The repository root (tests/web/../..). */
export const REPO_ROOT = path.resolve(HERE, '..', '..');

/** client/web, whose node_modules holds playwright-core. */
export const WEB_ROOT = path.join(REPO_ROOT, 'client', 'web');

/**
 * playwright-core, resolved from client/web/node_modules (tests/web has no node_modules).
 * @returns {typeof import('playwright-core')}
 */
export function loadPlaywright() {
  const require = createRequire(path.join(WEB_ROOT, 'package.json'));
  try {
    return require('playwright-core');
  } catch (e) {
    throw new Error(
      `playwright-core is not installed: run \`npm ci\` in ${WEB_ROOT} (${e.message})`,
      { cause: e },
    );
  }
}

/** The Chromium binary: $CHROMIUM, else /usr/bin/chromium. */
export function chromiumPath() {
  return process.env.CHROMIUM || '/usr/bin/chromium';
}

/**
 * Launches headless Chromium with a fake camera (fed from `y4m` when given, else Chromium's
 * built-in test pattern) and opens one page in a fresh context that accepts self-signed
 * certificates (arlightd's) and has the camera and motion-sensor permissions granted.
 *
 * @param {object} [options]
 * @param {string|null} [options.y4m] absolute path of a `.y4m` file for the fake camera
 * @param {boolean} [options.headless]
 * @param {string[]} [options.extraArgs] more Chromium switches
 * @param {object} [options.contextOptions] more Playwright `browser.newContext` options
 * @returns {Promise<{browser: import('playwright-core').Browser,
 *   context: import('playwright-core').BrowserContext, page: import('playwright-core').Page}>}
 */
export async function launchChromium({
  y4m = null,
  headless = true,
  extraArgs = [],
  contextOptions = {},
} = {}) {
  const executablePath = chromiumPath();
  if (!fs.existsSync(executablePath)) {
    throw new Error(`Chromium not found at ${executablePath} (set $CHROMIUM)`);
  }
  if (y4m !== null && y4m !== undefined) {
    if (!path.isAbsolute(y4m)) throw new Error(`y4m must be an absolute path, got ${y4m}`);
    if (!/y4m$/i.test(y4m)) {
      throw new Error(`Chromium reads a fake-camera file as Y4M only if its name ends in "y4m": ${y4m}`);
    }
    if (!fs.existsSync(y4m)) throw new Error(`y4m file not found: ${y4m}`);
  }
  const { chromium } = loadPlaywright();
  const args = [
    '--use-angle=swiftshader',
    '--enable-unsafe-swiftshader',
    '--use-fake-ui-for-media-stream',
    '--use-fake-device-for-media-stream',
    y4m ? `--use-file-for-fake-video-capture=${y4m}` : null,
    '--autoplay-policy=no-user-gesture-required',
    ...extraArgs,
  ].filter(Boolean);
  const browser = await chromium.launch({ executablePath, headless, args });
  try {
    const context = await browser.newContext({
      ignoreHTTPSErrors: true,
      permissions: ['camera', 'accelerometer', 'gyroscope', 'magnetometer'],
      ...contextOptions,
    });
    const page = await context.newPage();
    return { browser, context, page };
  } catch (e) {
    await browser.close();
    throw e;
  }
}

/** One CDP session per page, and which sensor overrides it has enabled. */
const sessions = new WeakMap();

/**
 * @param {import('playwright-core').Page} page
 * @returns {Promise<{cdp: import('playwright-core').CDPSession, enabled: Set<string>,
 *   deviceOrientation: boolean}>}
 */
async function sessionFor(page) {
  let s = sessions.get(page);
  if (!s) {
    s = (async () => ({
      cdp: await page.context().newCDPSession(page),
      enabled: new Set(),
      deviceOrientation: false,
    }))();
    sessions.set(page, s);
  }
  return s;
}

/** The Generic Sensor override types this harness handles. */
export const ORIENTATION_TYPES = Object.freeze(['absolute-orientation', 'relative-orientation']);

/**
 * Replaces the page's orientation sensor(s) by virtual ones (idempotent). Call it before the
 * page starts its sensor; {@link overrideOrientation} calls it too.
 * @param {import('playwright-core').Page} page
 * @param {string|string[]} [types] 'absolute-orientation' and/or 'relative-orientation'
 */
export async function enableOrientationOverride(page, types = 'absolute-orientation') {
  const s = await sessionFor(page);
  for (const type of Array.isArray(types) ? types : [types]) {
    if (!ORIENTATION_TYPES.includes(type)) throw new RangeError(`unknown orientation type ${type}`);
    if (s.enabled.has(type)) continue;
    if (s.deviceOrientation) {
      throw new Error(
        'enableOrientationOverride: this page has a DeviceOrientation override; Chromium 156 ' +
        'mishandles mixing it with Emulation sensor overrides, so use a fresh page for each',
      );
    }
    await s.cdp.send('Emulation.setSensorOverrideEnabled', { enabled: true, type });
    s.enabled.add(type);
  }
}

/**
 * Scales to unit length (keeping the sign), rejecting zero or non-finite quaternions.
 * @param {{x: number, y: number, z: number, w: number}} q
 * @returns {{x: number, y: number, z: number, w: number}}
 */
function unitQuaternion({ x, y, z, w }) {
  const n = Math.hypot(x, y, z, w);
  if (!(n > 0) || !Number.isFinite(n)) {
    throw new RangeError(`not a rotation quaternion: {x: ${x}, y: ${y}, z: ${z}, w: ${w}}`);
  }
  return { x: x / n, y: y / n, z: z / n, w: w / n };
}

/**
 * Sets the orientation the page's AbsoluteOrientationSensor (and `deviceorientationabsolute`)
 * reads, via CDP `Emulation.setSensorOverrideReadings`.
 *
 * @param {import('playwright-core').Page} page
 * @param {{x: number, y: number, z: number, w: number}} quaternion device → earth (ENU), the
 *   Generic Sensor API's convention; normalised before sending
 * @param {{type?: 'absolute-orientation'|'relative-orientation'|'both'}} [options]
 * @returns {Promise<{x: number, y: number, z: number, w: number}>} what the page will read:
 *   {@link chromiumRoundedQuaternion} of the normalised quaternion
 */
export async function overrideOrientation(page, quaternion, { type = 'absolute-orientation' } = {}) {
  const types = type === 'both' ? [...ORIENTATION_TYPES] : [type];
  const q = unitQuaternion(quaternion);
  await enableOrientationOverride(page, types);
  const { cdp } = await sessionFor(page);
  for (const t of types) {
    await cdp.send('Emulation.setSensorOverrideReadings', { type: t, reading: { quaternion: q } });
  }
  return chromiumRoundedQuaternion(q);
}

/**
 * The RelativeOrientationSensor (and `deviceorientation`) variant of {@link overrideOrientation}.
 * @param {import('playwright-core').Page} page
 * @param {{x: number, y: number, z: number, w: number}} quaternion
 * @returns {Promise<{x: number, y: number, z: number, w: number}>}
 */
export function overrideRelativeOrientation(page, quaternion) {
  return overrideOrientation(page, quaternion, { type: 'relative-orientation' });
}

/**
 * Sets `deviceorientation`'s angles exactly (DevTools' older path; iOS-style pages). Also feeds
 * RelativeOrientationSensor, not AbsoluteOrientationSensor.
 * @param {import('playwright-core').Page} page
 * @param {{alpha: number, beta: number, gamma: number}} angles degrees
 */
export async function overrideDeviceOrientation(page, { alpha, beta, gamma }) {
  const s = await sessionFor(page);
  if (s.enabled.size) {
    throw new Error(
      'overrideDeviceOrientation: this page already has Emulation orientation overrides ' +
      `(${[...s.enabled].join(', ')}); Chromium 156 refuses or mishandles mixing the two ` +
      'mechanisms, so use a fresh page for each',
    );
  }
  await s.cdp.send('DeviceOrientation.setDeviceOrientationOverride', { alpha, beta, gamma });
  s.deviceOrientation = true;
}

/**
 * Removes this harness' sensor overrides from the page.
 * @param {import('playwright-core').Page} page
 */
export async function clearOrientationOverrides(page) {
  const s = sessions.get(page);
  if (!s) return;
  const state = await s;
  for (const type of state.enabled) {
    await state.cdp.send('Emulation.setSensorOverrideEnabled', { enabled: false, type });
  }
  state.enabled.clear();
  if (state.deviceOrientation) {
    await state.cdp.send('DeviceOrientation.clearDeviceOrientationOverride');
    state.deviceOrientation = false;
  }
}

/** Chromium's kOrientationQuaternionRoundingMultiple: 0.1° in radians. */
const QUAT_ROUNDING = 0.0017453292519943296;

/** Chromium's RoundToMultiple (halves away from zero). */
function roundToMultiple(value, multiple) {
  const scaled = value / multiple;
  return value < 0 ? -multiple * Math.floor(-scaled + 0.5) : multiple * Math.floor(scaled + 0.5);
}

/**
 * What a page reads from an orientation sensor whose true reading is `q`: a port of Chromium's
 * RoundOrientationQuaternionReading (services/device/generic_sensor/platform_sensor_util.cc),
 * which rounds the rotation angle and the axis' azimuth and elevation to multiples of 0.1°.
 * Matches Chromium 156's output bit for bit.
 * @param {{x: number, y: number, z: number, w: number}} q unit quaternion
 * @returns {{x: number, y: number, z: number, w: number}}
 */
export function chromiumRoundedQuaternion({ x, y, z, w }) {
  const halfAngle = Math.acos(w);
  const roundedHalf = roundToMultiple(halfAngle * 2, QUAT_ROUNDING) / 2;
  if (roundedHalf === 0) return { x: 0, y: 0, z: 0, w: 1 };
  let s = Math.sin(halfAngle);
  let ax = x / s;
  let ay = y / s;
  let az = z / s;
  const xy = Math.sqrt(ax * ax + ay * ay);
  const azim = roundToMultiple(Math.atan2(ax, ay), QUAT_ROUNDING);
  const elev = roundToMultiple(Math.atan2(az, xy), QUAT_ROUNDING);
  ax = Math.sin(azim) * Math.cos(elev);
  ay = Math.cos(azim) * Math.cos(elev);
  az = Math.sin(elev);
  s = Math.sin(roundedHalf);
  return { x: ax * s, y: ay * s, z: az * s, w: Math.cos(roundedHalf) };
}

/**
 * BT.709 limited-range ("studio swing") Y′CbCr of an sRGB-encoded colour, the encoding Chromium
 * 156 assumes for the fake camera's I420 (measured: BT.601-encoded red 200,40,40 comes back as
 * 213,55,37, BT.709-encoded within ±1): Y 16…235, Cb/Cr 16…240.
 * @param {number} r 0…255
 * @param {number} g 0…255
 * @param {number} b 0…255
 * @returns {[number, number, number]} unrounded [Y, Cb, Cr]
 */
export function rgbToYCbCr709Limited(r, g, b) {
  const Kr = 0.2126;
  const Kb = 0.0722;
  const Kg = 1 - Kr - Kb;
  const R = r / 255;
  const G = g / 255;
  const B = b / 255;
  const Y = Kr * R + Kg * G + Kb * B;
  const Pb = (B - Y) / (2 * (1 - Kb));
  const Pr = (R - Y) / (2 * (1 - Kr));
  return [16 + 219 * Y, 128 + 224 * Pb, 128 + 224 * Pr];
}

/** Rounds and clamps to 0…255. */
const u8 = (v) => Math.min(255, Math.max(0, Math.round(v)));

/**
 * Writes a YUV4MPEG2 file that Chromium's fake camera plays (see the file comment for the header
 * and what Chromium checks): 4:2:0, chroma the mean of each 2×2 block (centre siting, hence
 * `C420jpeg`), BT.709 limited range.
 *
 * @param {string} file output path; Chromium wants the name to end in `.y4m`
 * @param {number} width even
 * @param {number} height even
 * @param {Uint8Array[]} frames each width × height × 3 bytes, RGB, top row first
 * @param {number} [fps] a positive integer (Chromium divides F's numerator by its denominator
 *   as integers)
 * @returns {{header: string, frameBytes: number, bytes: number}}
 */
export function writeY4M(file, width, height, frames, fps = 30) {
  if (!Number.isInteger(width) || !Number.isInteger(height) || width <= 0 || height <= 0 ||
      width % 2 || height % 2) {
    throw new RangeError(`Y4M size must be positive and even, got ${width}×${height}`);
  }
  if (!Number.isInteger(fps) || fps <= 0) {
    throw new RangeError(`fps must be a positive integer, got ${fps}`);
  }
  if (!Array.isArray(frames) || frames.length === 0) throw new RangeError('no frames');
  const header = `YUV4MPEG2 W${width} H${height} F${fps}:1 Ip A1:1 C420jpeg XCOLORRANGE=LIMITED\n`;
  if (header.length >= 200) throw new RangeError('Y4M header too long for Chromium (200 bytes)');

  const cw = width / 2;
  const ch = height / 2;
  const ySize = width * height;
  const cSize = cw * ch;
  const frameBytes = ySize + 2 * cSize;
  const out = Buffer.alloc(6 + frameBytes);
  out.write('FRAME\n', 0, 'latin1');
  const Y = out.subarray(6, 6 + ySize);
  const U = out.subarray(6 + ySize, 6 + ySize + cSize);
  const V = out.subarray(6 + ySize + cSize);

  const fd = fs.openSync(file, 'w');
  try {
    fs.writeSync(fd, header, null, 'latin1');
    frames.forEach((rgb, i) => {
      if (!rgb || rgb.length !== ySize * 3) {
        const got = rgb ? rgb.length : rgb;
        throw new RangeError(`frame ${i}: expected ${ySize * 3} RGB bytes, got ${got}`);
      }
      for (let p = 0; p < ySize; p++) {
        Y[p] = u8(rgbToYCbCr709Limited(rgb[3 * p], rgb[3 * p + 1], rgb[3 * p + 2])[0]);
      }
      for (let cy = 0; cy < ch; cy++) {
        for (let cx = 0; cx < cw; cx++) {
          let cb = 0;
          let cr = 0;
          for (let dy = 0; dy < 2; dy++) {
            for (let dx = 0; dx < 2; dx++) {
              const p = 3 * ((2 * cy + dy) * width + 2 * cx + dx);
              const [, b, r] = rgbToYCbCr709Limited(rgb[p], rgb[p + 1], rgb[p + 2]);
              cb += b;
              cr += r;
            }
          }
          U[cy * cw + cx] = u8(cb / 4);
          V[cy * cw + cx] = u8(cr / 4);
        }
      }
      fs.writeSync(fd, out);
    });
  } finally {
    fs.closeSync(fd);
  }
  return { header, frameBytes, bytes: header.length + frames.length * (6 + frameBytes) };
}

/**
 * A solid-colour RGB frame for {@link writeY4M}.
 * @param {number} width
 * @param {number} height
 * @param {[number, number, number]} rgb
 * @returns {Uint8Array}
 */
export function solidFrame(width, height, [r, g, b]) {
  const f = new Uint8Array(width * height * 3);
  for (let i = 0; i < f.length; i += 3) {
    f[i] = r;
    f[i + 1] = g;
    f[i + 2] = b;
  }
  return f;
}
