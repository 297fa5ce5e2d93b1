// The page's marker tracking step (client/web/src/marker.js, opencv.js) on frames arlight-sim
// rendered of a phone orbiting an ArUco marker, against the simulator's true poses: the frames
// are the Y4M the browser tests feed Chromium's camera (its luma), so this is what the page sees.
// Needs ARLIGHT_BIN (ctest sets it).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import { createRequire } from 'node:module';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

import { focalEstimate, focalFromMarkerViews, homography } from '../../client/web/src/intrinsics.js';
import { createMarkerTracker } from '../../client/web/src/marker.js';
import { quatConjugate, quatMultiply, quatRotateVector } from '../../client/web/src/orientation.js';

const HERE = path.dirname(fileURLToPath(import.meta.url));
const SOURCE = path.resolve(HERE, '..', '..');
const BIN = process.env.ARLIGHT_BIN;

// The module, once initialised. Wrapped: the emscripten Module is itself a thenable whose then()
// hands back the Module, so resolving a promise with it never settles.
function loadOpenCv() {
  const require = createRequire(path.join(SOURCE, 'client', 'web', 'package.json'));
  const cv = require('@techstark/opencv-js');
  return new Promise((resolve) => {
    if (cv.getBuildInformation) resolve({ cv });
    else cv.onRuntimeInitialized = () => resolve({ cv });
  });
}

// The luma planes of a YUV4MPEG2 file (limited range, expanded to 0-255).
function readY4mLuma(file) {
  const bytes = fs.readFileSync(file);
  const headerEnd = bytes.indexOf(0x0a);
  const header = bytes.subarray(0, headerEnd).toString();
  const width = Number(/ W(\d+)/.exec(header)[1]);
  const height = Number(/ H(\d+)/.exec(header)[1]);
  const frameBytes = 6 + (width * height * 3) / 2;  // "FRAME\n", Y, U, V
  const frames = [];
  for (let at = headerEnd + 1; at + frameBytes <= bytes.length; at += frameBytes) {
    const y = bytes.subarray(at + 6, at + 6 + width * height);
    frames.push(Uint8Array.from(y, (v) => Math.max(0, Math.min(255, Math.round(((v - 16) * 255) / 219)))));
  }
  return { width, height, frames };
}

test('the marker pose from a simulated orbit is within 2 cm and 2 degrees of the truth', { timeout: 120000 }, async () => {
  assert.ok(BIN, 'ARLIGHT_BIN must be set (ctest does)');
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'arlight-web-marker-'));
  try {
    execFileSync(path.join(BIN, 'arlight-sim'), [
      '--env', path.join(SOURCE, 'data/probes/venice.exr'), '--out', path.join(dir, 'rec'),
      '--frames', '16', '--trajectory', 'orbit', '--marker', '7,0.2', '--seed', '2',
      '--y4m', path.join(dir, 'camera.y4m'),
    ], { stdio: 'pipe' });
    const truth = JSON.parse(fs.readFileSync(path.join(dir, 'rec', 'truth', 'truth.json')));
    const k = JSON.parse(fs.readFileSync(path.join(dir, 'rec', 'recording.json'))).camera;
    const video = readY4mLuma(path.join(dir, 'camera.y4m'));
    const { cv } = await loadOpenCv();
    const tracker = createMarkerTracker(cv, { id: 7, size: 0.2 });
    const marker = truth.marker.pose;
    const errorsCm = [];
    const errorsDeg = [];
    const views = [];
    const reprojection = [];
    let visible = 0;
    video.frames.forEach((gray, i) => {
      if (!truth.marker_visible[i]) return;
      ++visible;
      const found = tracker.detect(gray, video.width, video.height, k);
      if (!found || found.refused) return;
      reprojection.push(found.reprojectionPx);
      views.push(found.corners);
      // The truth: camera_from_marker = inverse(world_from_camera) * world_from_marker.
      const cam = truth.poses[i];
      const qCamInv = quatConjugate(cam.orientation);
      const q = quatMultiply(qCamInv, marker.orientation);
      const t = quatRotateVector(qCamInv, marker.position.map((v, a) => v - cam.position[a]));
      errorsCm.push(100 * Math.hypot(...found.translation.map((v, a) => v - t[a])));
      const dot = Math.abs(q.reduce((s, v, a) => s + v * found.rotation[a], 0));
      errorsDeg.push((2 * Math.acos(Math.min(1, dot)) * 180) / Math.PI);
    });
    tracker.delete();
    assert.ok(visible >= 8, `the marker was visible in only ${visible} frames`);
    assert.equal(errorsCm.length, visible, `tracked ${errorsCm.length} of ${visible} visible frames`);
    const max = (v) => Math.max(...v);
    console.log(`marker: ${errorsCm.length} frames, position error max ${max(errorsCm).toFixed(2)} cm, ` +
      `angle error max ${max(errorsDeg).toFixed(2)} deg, reprojection max ${max(reprojection).toFixed(2)} px`);
    assert.ok(max(errorsCm) < 2, `position error up to ${max(errorsCm).toFixed(2)} cm`);
    assert.ok(max(errorsDeg) < 2, `angle error up to ${max(errorsDeg).toFixed(2)} deg`);

    // The focal length from the same views (the page's intrinsics refinement), against the
    // simulator's: within 2 %. A wrong guess of the page's default field of view does not
    // enter: only the corners do.
    const { focal: f, relativeError } = focalEstimate(views, (video.width - 1) / 2, (video.height - 1) / 2);
    console.log(`focal length from ${views.length} views: ${f.toFixed(1)} px, truth ${k.fx.toFixed(1)} px ` +
      `(${((f / k.fx - 1) * 100).toFixed(2)} %, standard error ${(relativeError * 100).toFixed(2)} %)`);
    // The standard error is honest: the truth within three of it.
    assert.ok(Math.abs(f / k.fx - 1) < 3 * relativeError, 'the focal length is further off than its error says');
    assert.ok(Math.abs(f / k.fx - 1) < 0.02, `focal ${f.toFixed(1)} px against ${k.fx.toFixed(1)}`);
  } finally {
    fs.rmSync(dir, { recursive: true, force: true });
  }
});

test('a homography and a focal length from exact projections', () => {
  // A square at 1 m seen 35 degrees off its normal by a camera of f = 500 px.
  const f = 500;
  const tilt = (35 * Math.PI) / 180;
  const project = ([x, y]) => {
    const X = 0.1 * x;
    const Y = 0.1 * y * Math.cos(tilt);
    const Z = 1 + 0.1 * y * Math.sin(tilt);
    return [(f * X) / Z, (f * Y) / Z];
  };
  const plane = [[-1, 1], [1, 1], [1, -1], [-1, -1]];
  const image = plane.map(project);
  const H = homography(plane, image);
  for (const [i, p] of plane.entries()) {
    const w = H[2][0] * p[0] + H[2][1] * p[1] + H[2][2];
    assert.ok(Math.abs((H[0][0] * p[0] + H[0][1] * p[1] + H[0][2]) / w - image[i][0]) < 1e-9);
    assert.ok(Math.abs((H[1][0] * p[0] + H[1][1] * p[1] + H[1][2]) / w - image[i][1]) < 1e-9);
  }
  const corners = image.flatMap(([u, v]) => [u + 320, v + 240]);
  assert.ok(Math.abs(focalFromMarkerViews([corners], 320, 240) - f) < 1e-6);
  // Square to the camera: nothing to tell.
  const square = plane.flatMap(([x, y]) => [320 + 50 * x, 240 + 50 * y]);
  assert.equal(focalFromMarkerViews([square], 320, 240), null);
  assert.throws(() => homography([[0, 0], [0, 0], [0, 0], [0, 0]], image), /degenerate/);
});
