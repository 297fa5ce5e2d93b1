// The page's marker tracking end to end in headless Chromium: arlight-sim renders a phone
// orbiting an ArUco marker (id 7, 20 cm) as the fake camera's video, the orientation sensor
// follows the same trajectory, and the page's worker (opencv.js) with the C++ pose filter must
// put the camera where the simulator says, the object where its truth projects (the sphere, the
// bunny, Suzanne), and refine a wrong field of view from the marker's views. Run by ctest
// (tests/web/web_tests.cmake).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';

import { launchChromium } from './harness.mjs';
import { simulateRoom, startDaemon, playRoom } from './phone_session.mjs';
import { trueCameraInMarker, trueObjectPixel } from './marker_truth.mjs';

const BIN = process.env.ARLIGHT_BIN;
const SOURCE = process.env.ARLIGHT_SOURCE_DIR;
const TOKEN = 'web-marker-token-0123456789';
const MARKER = { id: 7, size: 0.2 };

const sub = (a, b) => a.map((v, i) => v - b[i]);
const angleDeg = (a, b) => {
  const dot = Math.abs(a.reduce((s, v, i) => s + v * b[i], 0));
  return (2 * Math.acos(Math.min(1, dot)) * 180) / Math.PI;
};

// Position (cm) and angle (degrees) errors of the page's tracks against the truth, on the frames
// where the marker is visible; `after` keeps only tracks from that media time on.
function trackErrors(tracks, room, pick, after = -1) {
  const out = { cm: [], deg: [], frames: new Set() };
  for (const t of tracks) {
    const i = Math.round(t.media_time * room.fps);
    if (t.media_time < after || i >= room.frames || !room.truth.marker_visible[i]) continue;
    const want = trueCameraInMarker(room.truth, i);
    out.cm.push(100 * Math.hypot(...sub(t[pick].position, want.position)));
    out.deg.push(angleDeg(t[pick].orientation, want.orientation));
    out.frames.add(i);
    if (process.env.ARLIGHT_DEBUG) console.log(pick, i, t.media_time, out.cm.at(-1).toFixed(2), out.deg.at(-1).toFixed(2), t.reprojection_px.toFixed(2));
  }
  return out;
}

const max = (v) => Math.max(...v);

test('the page tracks the marker, stands the object on it and refines its focal length', { timeout: 300000 }, async () => {
  assert.ok(BIN && SOURCE, 'ARLIGHT_BIN and ARLIGHT_SOURCE_DIR must be set (ctest does)');
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'arlight-web-marker-'));
  const room = simulateRoom({
    bin: BIN, probe: path.join(SOURCE, 'data/probes/venice.exr'), dir, frames: 32, fps: 2,
    width: 640, height: 480, seed: 5, extraArgs: ['--trajectory', 'orbit', '--marker', `${MARKER.id},${MARKER.size}`],
  });
  const visible = room.truth.marker_visible.filter(Boolean).length;
  assert.ok(visible >= 16, `the marker is visible in only ${visible} of ${room.frames} frames`);
  const d = await startDaemon({ bin: BIN, dir: path.join(dir, 'daemon'), webRoot: path.join(BIN, 'web'), token: TOKEN });
  let { browser, page } = await launchChromium({ y4m: room.y4m });
  try {
    // 1. The simulator's field of view: every visible frame's pose, and the object's pixels.
    const pageErrors = [];
    page.on('pageerror', (e) => pageErrors.push(e.message));
    const probes = [];
    await playRoom(page, d.url, room, {
      fragment: `&marker=${MARKER.id},${MARKER.size}`,
      onTick: async (s) => {
        if (!s.tracked_frames || s.lighting === 'none') return;
        const p = await page.evaluate(() => window.arlight.probe());
        // Only composites drawn with the pose tracked in the very frame they show.
        if (p && p.media_time === p.tracked_media_time && !probes.some((q) => q.media_time === p.media_time))
          probes.push(p);
      },
    });
    const status = await page.evaluate(() => window.arlight.status());
    const tracks = await page.evaluate(() => window.arlight.tracks());
    assert.deepEqual(pageErrors, []);
    assert.equal(status.last_error, '');
    // Issue 37 §1: arlightd asked for this 640x480 camera's frames at 320x240 (its map and its
    // alignment resolve no more), the page sent them so, and arlightd took them.
    assert.deepEqual(status.advised_size, [320, 240]);
    assert.ok(status.frames_sent > 0 && status.frames_processed >= 0.9 * status.frames_sent,
      `${status.frames_processed} of ${status.frames_sent} reduced frames processed`);
    const raw = trackErrors(tracks, room, 'raw');
    const smoothed = trackErrors(tracks, room, 'smoothed');
    console.log(`tracked ${raw.frames.size} of ${visible} visible frames (opencv.js ready at ${status.tracker_ready_media_time} s; ` +
      `worker ${status.track_ms.toFixed(0)} ms): raw max ${max(raw.cm).toFixed(2)} cm ${max(raw.deg).toFixed(2)} deg, ` +
      `smoothed max ${max(smoothed.cm).toFixed(2)} cm ${max(smoothed.deg).toFixed(2)} deg`);
    // The page shows each frame for half a second: once opencv.js is loaded the worker takes
    // nearly every one (a frame that shows while the worker is still busy, or the last one when
    // the video ends, is skipped; one or two in a run on this machine).
    assert.equal(status.tracker, 'ready');
    const offered = room.truth.marker_visible.map((v, i) => (v && i / room.fps >= status.tracker_ready_media_time - 0.01 ? i : -1))
      .filter((i) => i >= 0);
    assert.ok(offered.length >= 16, `opencv.js was ready only at ${status.tracker_ready_media_time} s`);
    assert.ok(raw.frames.size >= 0.85 * offered.length, `tracked ${raw.frames.size} of the ${offered.length} visible frames ` +
      `from the first one offered to the tracker; not frames ${offered.filter((i) => !raw.frames.has(i)).join(' ')}`);
    assert.ok(max(raw.cm) < 2 && max(raw.deg) < 2, `raw pose up to ${max(raw.cm)} cm, ${max(raw.deg)} deg off`);
    assert.ok(max(smoothed.cm) < 2 && max(smoothed.deg) < 2,
      `smoothed pose up to ${max(smoothed.cm)} cm, ${max(smoothed.deg)} deg off`);
    assert.equal(status.tracking, 'marker');

    // The composite: the object's centre where the truth projects it, drawn over the camera's
    // pixels there, and the camera's pixels kept away from it.
    assert.ok(probes.length >= 4, `only ${probes.length} composites of tracked frames`);
    const diff = (a, b) => a.reduce((s, v, k) => s + Math.abs(v - b[k]), 0);
    // Off by no more than 2 cm across the line of sight would move it.
    const offsets = probes.map((p) => {
      const want = trueObjectPixel(room.truth, Math.round(p.media_time * room.fps), room.camera, MARKER.size);
      const px = Math.hypot(p.centre[0] - want.pixel[0], p.centre[1] - want.pixel[1]);
      return { px, cm: (100 * px * want.distance) / room.camera.fx };
    });
    const worst = offsets.reduce((a, b) => (b.cm > a.cm ? b : a));
    console.log(`object centre: ${probes.length} composites, up to ${worst.px.toFixed(1)} px ` +
      `(${worst.cm.toFixed(2)} cm at its distance) from the truth's projection`);
    assert.ok(worst.cm < 2, `the object's centre up to ${worst.cm.toFixed(2)} cm from where the truth puts it`);
    for (const p of probes) {
      assert.ok(diff(p.at_corner.composite, p.at_corner.frame) <= 3, `corner ${JSON.stringify(p.at_corner)}`);
      assert.ok(diff(p.at_object.composite, p.at_object.frame) > 20, `object ${JSON.stringify(p.at_object)}`);
    }
    // The shadow on the page (tutorial §6: the catcher's factors blended into the frame on the
    // GPU): the floor just in front of the object darker than the camera saw it in every
    // composite of a tracked frame, and by at least 8 % in the median one (its contact shadow;
    // the hard shadows, when the room has compact lights, fall elsewhere).
    const sum = (c) => c[0] + c[1] + c[2];
    for (const p of probes) {
      assert.ok(p.at_floor, `no floor pixel: ${JSON.stringify(p)}`);
      assert.ok(sum(p.at_floor.frame) > 60, `the floor is too dark to see a shadow on: ${JSON.stringify(p.at_floor)}`);
      assert.ok(sum(p.at_floor.composite) <= 0.98 * sum(p.at_floor.frame), `floor ${JSON.stringify(p.at_floor)}`);
    }
    const ratios = probes.map((p) => sum(p.at_floor.composite) / sum(p.at_floor.frame)).sort((a, b) => a - b);
    console.log(`shadow: the floor in front of the object at ${ratios.map((r) => r.toFixed(2)).join(' ')} of the frame; ` +
      `hard shadows ${probes.map((p) => p.shadow_lights).join(' ')}; budget ${status.shadow_light_budget} of ` +
      `${status.max_shadow_lights} at ${status.target_fps} fps`);
    assert.ok(ratios[Math.floor(ratios.length / 2)] <= 0.92, `median floor ratio ${ratios[Math.floor(ratios.length / 2)]}`);
    assert.ok(status.shadow_light_budget >= 1 && status.shadow_light_budget <= status.max_shadow_lights);
    assert.equal(status.max_shadow_lights, 16);
    assert.equal(status.target_fps, 30);

    // The other models: the page fetches them (re-encoded without Draco) and stands them on the
    // marker; a missing one is named and the object stays.
    for (const [model, vertices] of [['bunny', 2826], ['suzanne', 7503]]) {
      await page.selectOption('#model', model);
      await page.waitForFunction((m) => window.arlight.status().model === m, model, { timeout: 10000 });
      assert.equal((await page.evaluate(() => window.arlight.status())).model_vertices, vertices);
      const p = await page.evaluate(() => window.arlight.probe());
      assert.ok(p && diff(p.at_object.composite, p.at_object.frame) > 20, `${model}: ${JSON.stringify(p && p.at_object)}`);
    }
    await page.evaluate(() => {
      const option = document.createElement('option');
      option.value = 'missing';
      document.getElementById('model').append(option);
    });
    await page.selectOption('#model', 'missing');
    await page.waitForFunction(() => /model missing: 404/.test(window.arlight.status().last_error), null, { timeout: 10000 });
    assert.equal((await page.evaluate(() => window.arlight.status())).model, 'suzanne');

    // 2. A field of view 12 % too wide (a phone's default guess): the marker's views refine the
    // focal length to within 2 % of the simulator's, arlightd takes the new intrinsics, and the
    // poses after it are right. A second browser: the fake camera plays on from where it was in
    // the first.
    await browser.close();
    ({ browser, page } = await launchChromium({ y4m: room.y4m }));
    const second = page;
    second.on('pageerror', (e) => pageErrors.push(e.message));
    await playRoom(second, d.url, room, { fragment: `&marker=${MARKER.id},${MARKER.size}`, fov: room.vfovDeg * 1.12 });
    const refined = await second.evaluate(() => window.arlight.status());
    assert.deepEqual(pageErrors, []);
    assert.equal(refined.last_error, '', 'arlightd refused the refined intrinsics?');
    assert.equal(refined.intrinsics, 'refined', `focal ${refined.focal_px} px, standard error ${refined.focal_error}`);
    console.log(`focal length: ${refined.focal_px.toFixed(1)} px from a ${(room.vfovDeg * 1.12).toFixed(1)}° start, ` +
      `truth ${room.camera.fx.toFixed(1)} px (${((refined.focal_px / room.camera.fx - 1) * 100).toFixed(2)} %)`);
    assert.ok(Math.abs(refined.focal_px / room.camera.fx - 1) < 0.02, `focal ${refined.focal_px} px`);
    const after = trackErrors(await second.evaluate(() => window.arlight.tracks()), room, 'raw',
      refined.intrinsics_refined_media_time + 1 / room.fps);
    console.log(`after the refinement at ${refined.intrinsics_refined_media_time} s: ${after.frames.size} frames, ` +
      `raw max ${max(after.cm).toFixed(2)} cm ${max(after.deg).toFixed(2)} deg`);
    assert.ok(after.frames.size >= 4, `only ${after.frames.size} tracked frames after the refinement`);
    assert.ok(max(after.cm) < 2 && max(after.deg) < 2, `after the refinement up to ${max(after.cm)} cm, ${max(after.deg)} deg off`);
    assert.equal(refined.connected, true);
  } finally {
    await browser.close();
    await d.stop();
  }
  fs.rmSync(dir, { recursive: true, force: true });
});
