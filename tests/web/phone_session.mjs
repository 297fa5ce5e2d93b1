// A simulated phone for the browser client, shared by its end-to-end test and `make demo`:
// arlight-sim renders a room sweep as a recording (with its ground truth) and as a Y4M for
// Chromium's fake camera; arlightd runs with its web port; the page's orientation sensor is
// driven over CDP from the recording's true poses, in step with the video.
import { spawn, execFileSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';

import { enableOrientationOverride, overrideOrientation } from './harness.mjs';
import { sensorQuaternionFromCameraQuat } from '../../client/web/src/orientation.js';

/**
 * Renders the room: REC (recording + truth/) and camera.y4m in `dir`.
 * `extraArgs` go to arlight-sim (e.g. an orbit around a marker); `leadIn` frames of the first
 * view come first (the phone held still while the page connects).
 * @returns {{rec: string, y4m: string, poses: Array<{orientation: number[]}>, truth: object,
 *   camera: object, exposure: number, fps: number, frames: number, width: number,
 *   height: number, vfovDeg: number}}
 */
export function simulateRoom({
  bin, probe, dir, frames = 96, fps = 4, width = 320, height = 240, seed = 11, extraArgs = [],
  leadIn = 0,
}) {
  const rec = path.join(dir, 'rec');
  const y4m = path.join(dir, 'camera.y4m');
  execFileSync(path.join(bin, 'arlight-sim'), [
    '--env', probe, '--out', rec, '--frames', String(frames), '--fps', String(fps),
    '--size', `${width}x${height}`, '--gyro-drift', '0', '--seed', String(seed), '--y4m', y4m,
    ...extraArgs,
  ], { stdio: 'pipe' });
  const truth = JSON.parse(fs.readFileSync(path.join(rec, 'truth', 'truth.json')));
  if (leadIn > 0) holdFirstFrame(y4m, truth, leadIn, width, height);
  const { poses } = truth;
  const recording = JSON.parse(fs.readFileSync(path.join(rec, 'recording.json')));
  const k = recording.camera;
  return {
    rec, y4m, poses, truth, camera: k, fps, frames: frames + leadIn, width, height,
    exposure: recording.frames[0].exposure * recording.frames[0].gain,
    vfovDeg: (2 * Math.atan((0.5 * k.height) / k.fy) * 180) / Math.PI,
  };
}

// The phone held still on its first view for `count` frames before the recording starts: the
// video's first frame repeated, and the truth's first pose (and marker visibility) with it, so
// the page has connected before the room starts to move and every frame of it reaches arlightd.
function holdFirstFrame(y4m, truth, count, width, height) {
  const bytes = fs.readFileSync(y4m);
  const headerEnd = bytes.indexOf(0x0a) + 1;
  const frameBytes = 6 + (width * height * 3) / 2;  // "FRAME\n", Y, U, V
  const first = bytes.subarray(headerEnd, headerEnd + frameBytes);
  fs.writeFileSync(y4m, Buffer.concat([bytes.subarray(0, headerEnd), ...Array(count).fill(first),
    bytes.subarray(headerEnd)]));
  truth.poses = [...Array(count).fill(truth.poses[0]), ...truth.poses];
  if (truth.marker_visible)
    truth.marker_visible = [...Array(count).fill(truth.marker_visible[0]), ...truth.marker_visible];
}

// Each frame's index, written into the video itself: the fake camera's media times do not name
// the file's frames at 30 fps (one run here showed frame 27, due at 0.90 s, at media time 0.80 s,
// and 6.52 s at 2 fps for frame 13). Bits as 8×8 luma blocks along the bottom-left corner, bit 0
// first.
const kIndexBits = 12;
const kIndexBlock = 8;

/** Stamps every frame of `room`'s Y4M with its index (frameSyncedSensor reads it back). */
export function stampFrameIndices(room) {
  const { y4m, width: w, height: h } = room;
  const bytes = fs.readFileSync(y4m);
  const headerEnd = bytes.indexOf(0x0a) + 1;
  const frameBytes = 6 + (w * h * 3) / 2;
  if ((bytes.length - headerEnd) % frameBytes !== 0) throw new Error(`${y4m}: not whole ${w}x${h} I420 frames`);
  const frames = (bytes.length - headerEnd) / frameBytes;
  if (frames >= 1 << kIndexBits) throw new Error(`${frames} frames: more than ${kIndexBits} bits name`);
  for (let i = 0; i < frames; ++i) {
    const luma = headerEnd + i * frameBytes + 6;
    for (let b = 0; b < kIndexBits; ++b) {
      const value = (i >> b) & 1 ? 235 : 16;
      for (let y = h - kIndexBlock; y < h; ++y) bytes.fill(value, luma + y * w + b * kIndexBlock, luma + y * w + (b + 1) * kIndexBlock);
    }
  }
  fs.writeFileSync(y4m, bytes);
}

/**
 * The page's orientation sensor in step with its video, exactly: before the page loads, its
 * AbsoluteOrientationSensor is replaced by one that, as each video frame reaches the page
 * (requestVideoFrameCallback, before the page's own callback runs), reads the stamped index
 * (stampFrameIndices) of the frame the page will take and reports that frame's true pose, stamped
 * with the frame's capture time. The frames' indices by media time (the VideoFrame's timestamp,
 * as the page labels what it shows) are kept in window.__arlightFrameIndex. (Chromium's sensor
 * override over CDP arrives ~100 ms late: playRoom's pacing suits a few frames a second, not 30.)
 */
export async function frameSyncedSensor(page, room) {
  const readings = room.poses.map((p) => { const r = sensorReadingFor(p); return [r.x, r.y, r.z, r.w]; });
  await page.addInitScript(({ readings, bits, block }) => {
    const sensors = [];
    window.AbsoluteOrientationSensor = class extends EventTarget {
      constructor() {
        super();
        this.quaternion = null;
        this.timestamp = null;
        sensors.push(this);
      }
      start() {}
      stop() {}
    };
    const frameIndex = new Map();
    window.__arlightFrameIndex = frameIndex;
    const canvas = new OffscreenCanvas(bits * block, 1);
    const ctx = canvas.getContext('2d', { willReadFrequently: true });
    const request = HTMLVideoElement.prototype.requestVideoFrameCallback;
    // Within a frame callback, `new VideoFrame(video)` is whatever frame the video holds at that
    // instant: a frame or more newer than the callback's after a few milliseconds here. The page
    // gets the frame whose index was read (a clone), so its orientation is that frame's.
    let current = null;
    window.VideoFrame = new Proxy(window.VideoFrame, {
      construct(target, args, newTarget) {
        if (current && args[0] === current.video && args.length === 1) return current.frame.clone();
        return Reflect.construct(target, args, newTarget);
      },
    });
    HTMLVideoElement.prototype.requestVideoFrameCallback = function (callback) {
      return request.call(this, (now, metadata) => {
        const frame = new VideoFrame(this);
        ctx.drawImage(frame, 0, this.videoHeight - block / 2, bits * block, 1, 0, 0, bits * block, 1);
        const row = ctx.getImageData(0, 0, bits * block, 1).data;  // the stamp's middle row
        let index = 0;
        for (let b = 0; b < bits; ++b) if (row[4 * (b * block + block / 2)] > 128) index |= 1 << b;
        frameIndex.set(frame.timestamp / 1e6, index);
        if (index < readings.length) {
          for (const s of sensors) {
            s.quaternion = readings[index];
            // Read when the frame was taken (as the page works it out from the callback's).
            s.timestamp = metadata.captureTime + 1000 * (frame.timestamp / 1e6 - metadata.mediaTime);
            s.dispatchEvent(new Event('reading'));
          }
        }
        current = { video: this, frame };
        try {
          callback(now, metadata);
        } finally {
          current = null;
          frame.close();
        }
      });
    };
  }, { readings, bits: kIndexBits, block: kIndexBlock });
}

/**
 * arlightd on loopback with its web port serving `webRoot`; one device, "phone".
 * @returns {Promise<{url: string, web: number, log: () => string, stop: () => Promise<void>,
 *   kill: () => Promise<void>, adminFetch: (route: string) => Promise<Response>,
 *   adminGet: (route: string) => Promise<object>}>}
 */
export async function startDaemon({ bin, dir, webRoot, token, host = '127.0.0.1', webPort = 0 }) {
  fs.mkdirSync(dir, { recursive: true });
  fs.writeFileSync(path.join(dir, 'tokens'), `phone ${token}\n`);
  // `host`: the address it serves on (a shaped link's, bench/shaped_links.sh); admin on loopback.
  // `webPort`: the web port (0: any; a daemon taking over a dead one's page: the same).
  const daemon = spawn(path.join(bin, 'arlightd'), [
    '--listen', `${host}:0`, '--admin', '127.0.0.1:0', '--web', `${host}:${webPort}`,
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
      const ports = /listening on [0-9.]+:(\d+), admin on (\d+), web on (\d+)/.exec(out);
      if (url && ports) {
        clearTimeout(timer);
        resolve({ url: url[1], web: Number(ports[3]), admin: Number(ports[2]), banner: out });
      }
    });
    daemon.on('exit', (code) => reject(new Error(`arlightd exited (${code}): ${out}${err}`)));
  });
  const exited = new Promise((resolve) => daemon.on('exit', resolve));
  // SIGTERM: arlightd checkpoints its sessions, then exits.
  const stop = async () => {
    daemon.kill('SIGTERM');
    await exited;
  };
  // SIGKILL: gone with whatever no checkpoint holds (a crash, a machine lost).
  const kill = async () => {
    daemon.kill('SIGKILL');
    await exited;
  };
  // The admin API (its token from the data folder): `route`'s response, and its parsed JSON.
  const adminFetch = async (route) => {
    const token = fs.readFileSync(path.join(dir, 'data', 'admin.token'), 'utf8').split('\n')
      .map((l) => l.trim()).find((l) => l && !l.startsWith('#'));
    return fetch(`http://127.0.0.1:${ready.admin}${route}`, { headers: { Authorization: `Bearer ${token}` } });
  };
  const adminGet = async (route) => (await adminFetch(route)).json();
  return { ...ready, log: () => err, stop, kill, adminFetch, adminGet };
}

/** The sensor reading (device -> ENU, [x, y, z, w] as {x, y, z, w}) of a camera pose. */
export function sensorReadingFor(pose) {
  const [x, y, z, w] = sensorQuaternionFromCameraQuat(pose.orientation, 0);
  return { x, y, z, w };
}

/**
 * Opens the phone page at `url` and plays one pass of the room, keeping the orientation sensor on
 * the true pose of the frame the page is showing. The page reports the shown frame's media time
 * (Chromium's fake camera stamps frame i with i / fps); as soon as frame i shows, the sensor is
 * set to frame i + 1's pose, which reaches the page ~100 ms later (Chromium's sensor latency),
 * well before that frame is due. Pacing from the time the camera opened instead raced that
 * latency: one run in three put every frame's orientation one frame off. Before the page shows
 * its first frame, the pose follows the time since the camera opened. `onTick(status)` runs
 * between polls (every ~20 ms). `fragment` is added to the page's URL fragment; `fov` is the
 * page's starting field of view (default the simulator's). It returns once frame `lastFrame` (by
 * default the last) shows: the fake camera then starts the video again, with the sensor still
 * at the last pose.
 */
export async function playRoom(page, url, room, {
  onTick = async () => {}, timeoutMs = 150000, fragment = '', fov = room.vfovDeg,
  lastFrame = room.frames - 1,
} = {}) {
  await enableOrientationOverride(page);
  await overrideOrientation(page, sensorReadingFor(room.poses[0]));
  await page.goto(`${url}&autostart=1&fov=${fov}${fragment}`);
  let last = 0;
  const deadline = Date.now() + timeoutMs;
  while (Date.now() < deadline) {
    const status = await page.evaluate(() => window.arlight.status());
    let next = null;
    if (typeof status.frame_media_time === 'number') {
      const shown = Math.round(status.frame_media_time * room.fps);
      if (shown >= lastFrame) return;
      next = shown + 1;
    } else if (status.camera_opened_at) {
      next = Math.floor(((Date.now() - status.camera_opened_at) / 1000) * room.fps) + 1;
    }
    if (next !== null && next !== last && next < room.frames) {
      await overrideOrientation(page, sensorReadingFor(room.poses[next]));
      last = next;
    }
    await onTick(status);
    await new Promise((r) => setTimeout(r, 20));
  }
  throw new Error('the room did not play to its end in time');
}

/**
 * Bands 0-2 of a probe's SH (arlight-maps sh), scaled: what a session that assumed another
 * exposure than the video's should have captured.
 */
export function truthSh({ bin, envExr, dir, scale = 1 }) {
  execFileSync(path.join(bin, 'arlight-maps'), [
    'sh', '--input', envExr, '--order', '3', '--size', '256', '--out', dir,
  ], { stdio: 'pipe' });
  return JSON.parse(fs.readFileSync(path.join(dir, 'sh.json'))).coefficients
    .map((rgb) => rgb.map((v) => v * scale));
}
