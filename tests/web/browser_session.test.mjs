// A phone-shaped session end to end in a real headless Chromium (SwiftShader's WebGL2): the page
// arlightd serves, its WebAssembly build of the project's C++, a fake camera playing what
// arlight-sim rendered of a room (a Y4M), the orientation sensor fed through the DevTools
// protocol from the same trajectory in step with the video, and a real arlightd over wss on
// loopback. Run by ctest (tests/web/web_tests.cmake sets ARLIGHT_BIN and ARLIGHT_SOURCE_DIR).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';

import { launchChromium, enableOrientationOverride, overrideOrientation } from './harness.mjs';
import { simulateRoom, startDaemon, playRoom, truthSh, sensorReadingFor } from './phone_session.mjs';

const BIN = process.env.ARLIGHT_BIN;
const SOURCE = process.env.ARLIGHT_SOURCE_DIR;
const TOKEN = 'web-test-token-0123456789';

// Relative RMS difference of the irradiance two SH sets (bands 0-2, RGB) describe: by Parseval,
// the norm of the clamped-cosine-weighted coefficient differences (A0 = pi, A1 = 2pi/3,
// A2 = pi/4) over the norm of the reference's; independent of the basis' sign conventions.
function irradianceRelativeRms(flat, reference) {
  const a = (k) => (k === 0 ? Math.PI : k < 4 ? (2 * Math.PI) / 3 : Math.PI / 4);
  let num = 0;
  let den = 0;
  for (let k = 0; k < 9; ++k) {
    for (let c = 0; c < 3; ++c) {
      num += (a(k) * (flat[3 * k + c] - reference[k][c])) ** 2;
      den += (a(k) * reference[k][c]) ** 2;
    }
  }
  return Math.sqrt(num / den);
}

test('a phone-shaped session captures the room, gets lighting and renders the object', { timeout: 300000 }, async () => {
  assert.ok(BIN && SOURCE, 'ARLIGHT_BIN and ARLIGHT_SOURCE_DIR must be set (ctest does)');
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'arlight-web-session-'));
  // A sweep of the room at 2 frames a second, 320x240: a frame's pose must reach the page
  // (Chromium's sensor latency ~100 ms) before that frame, with margin on a loaded machine.
  // The phone holds still on its first view for 4 s while the page connects: every frame of the
  // sweep then reaches arlightd (without it, which of the first views were missed moved the
  // captured irradiance by a few per cent from run to run).
  const room = simulateRoom({ bin: BIN, probe: path.join(SOURCE, 'data/probes/venice.exr'), dir, frames: 72, fps: 2, leadIn: 8 });
  // The browser cannot report its exposure: arlightd assumes 1/60 s at gain 1, so its map is the
  // room's radiance scaled by the exposure the video was really taken at over that.
  const truth = truthSh({
    bin: BIN, envExr: path.join(room.rec, 'truth', 'env.exr'), dir: path.join(dir, 'sh'),
    scale: room.exposure / (1 / 60),
  });
  const d = await startDaemon({ bin: BIN, dir: path.join(dir, 'daemon'), webRoot: path.join(BIN, 'web'), token: TOKEN });
  const { browser, context, page } = await launchChromium({ y4m: room.y4m });
  try {
    const pageErrors = [];
    page.on('pageerror', (e) => pageErrors.push(e.message));
    const probes = [];
    const guides = [];  // the capture guide's elevation at each poll
    const views = [];   // the next view the guide follows, its elevation and its words
    let ticks = 0;
    await playRoom(page, d.url, room, {
      onTick: async (s) => {
        if (s.started) guides.push(s.guide_elevation_deg);
        // The panel updates once a second: its words are for the view it last read (guide_view).
        if (s.started && s.guide_view) views.push({ view: s.guide_view, elevation: s.guide_elevation_deg, text: s.guide });
        if (s.lighting === 'none' || probes.length >= 100 || ++ticks % 8) return;
        const p = await page.evaluate(() => window.arlight.probe());
        if (p) probes.push(p);
      },
    });
    // Let the last frames and a map set of the whole sweep arrive.
    await page.waitForFunction(() => {
      const s = window.arlight.status();
      return s.updates >= s.frames_sent - 1 && s.map_sets >= 1;
    }, null, { timeout: 60000 });
    const status = await page.evaluate(() => window.arlight.status());
    // Each frame went out with the orientation of the view it shows (the page pairs them when
    // the frame shows; the harness keeps the sensor on the frame's pose).
    const sent = await page.evaluate(() => window.arlight.sent());
    const angleDeg = (a, b) => (2 * Math.acos(Math.min(1, Math.abs(a.reduce((s, v, i) => s + v * b[i], 0)))) * 180) / Math.PI;
    const paired = sent.filter((f) => angleDeg(f.orientation, room.poses[Math.round(f.media_time * room.fps)].orientation) < 0.5);
    assert.ok(paired.length >= 0.95 * sent.length, `only ${paired.length} of ${sent.length} frames sent with their own orientation`);

    assert.deepEqual(pageErrors, []);
    assert.equal(status.connected, true);
    assert.equal(status.orientation, 'absolute-orientation-sensor');
    assert.ok(status.frames_sent >= room.frames - 8, `only ${status.frames_sent} of ${room.frames} frames sent`);
    assert.ok(status.frames_processed >= status.frames_sent * 0.9,
      `${status.frames_processed} of ${status.frames_sent} frames processed`);
    // A 320x240 camera into arlightd's map: its frames are wanted at their size, and at 2 a
    // second none is held back (the advice asks for at most 30 or, once they agree, 10).
    assert.deepEqual(status.advised_size, [320, 240]);
    assert.equal(status.frames_held_back, 0);
    // Loopback carries any frame at once: no byte advice (or one far over any frame), and the
    // page encodes at its best quality (a busy page or daemon must not read as a narrow uplink,
    // issue 36 §1).
    assert.ok(status.advised_frame_bytes === 0 || status.advised_frame_bytes > 100000,
      `advised ${status.advised_frame_bytes} bytes a frame on loopback`);
    assert.equal(status.jpeg_quality, 90);
    assert.ok(status.map_sets >= 1);
    assert.equal(status.lighting, 'maps');
    assert.ok(status.coverage > 0.9, `coverage ${status.coverage}`);
    // Before arlightd states a next view the guide asks for the ceiling first; once its updates
    // propose one (issue 48 §2), the guide points there: the proposal's elevation, in words.
    assert.equal(guides[0], 85);
    assert.ok(views.length > 0, 'no update proposed a view');
    for (const v of views) {
      assert.ok(Math.abs(Math.hypot(...v.view) - 1) < 1e-3, JSON.stringify(v));
      const elevation = (Math.asin(v.view[1]) * 180) / Math.PI;
      assert.ok(Math.abs(v.elevation - elevation) < 1e-6, JSON.stringify(v));
      assert.match(v.text, /^(turn (left|right|up|down)|look straight|hold here)/, JSON.stringify(v));
    }
    // ... and says how good the light is: swept all round, within a few per cent.
    assert.ok(status.light_error > 0 && status.light_error < 0.25, `light_error ${status.light_error}`);
    const lightingText = await page.$eval('#s-lighting', (e) => e.textContent);
    assert.match(lightingText, /light good to ±\d+ %/);
    assert.equal(status.last_error, '');
    // "Watch this room": /three.html for this session, with this device's credentials.
    const watch = await page.$eval('#s-watch', (a) => a.getAttribute('href'));
    assert.equal(watch, `three.html#session=${status.session_id}&device=phone&token=${TOKEN}`);
    // ... and as a QR code arlightd drew (an SVG the page loaded).
    const qr = await page.$eval('#s-watch-qr', (img) => ({ src: img.getAttribute('src'), width: img.naturalWidth, hidden: img.hidden }));
    assert.equal(qr.src, `qr.svg?three=session=${status.session_id}&device=phone&token=${TOKEN}`);
    assert.ok(qr.width > 0 && !qr.hidden, JSON.stringify(qr));
    // The room's irradiance as the session captured it, against the simulator's truth.
    const dc = status.sh[1] / truth[0][1];
    const rms = irradianceRelativeRms(status.sh, truth);
    console.log(`irradiance: mean ${((dc - 1) * 100).toFixed(1)} % off, relative RMS ${(rms * 100).toFixed(1)} %; ` +
      `${status.frames_processed} frames, coverage ${(status.coverage * 100).toFixed(0)} %, ` +
      `${status.fps.toFixed(1)} fps, render ${status.render_ms.toFixed(1)} ms, ` +
      `latency p50 ${status.latency_p50_ms.toFixed(0)} ms p99 ${status.latency_p99_ms.toFixed(0)} ms`);
    assert.ok(Math.abs(dc - 1) < 0.05, `mean irradiance ${((dc - 1) * 100).toFixed(1)} % off the truth`);
    assert.ok(rms < 0.05, `irradiance ${(rms * 100).toFixed(1)} % (relative RMS) off the truth`);

    // The composite: the object where the renderer put it, the camera's pixels elsewhere.
    const inside = probes.filter((p) => p.centre[0] > 20 && p.centre[0] < room.width - 20 &&
      p.centre[1] > 20 && p.centre[1] < room.height - 20);
    assert.ok(inside.length > 0, `the object was never in view (${probes.length} probes)`);
    const diff = (a, b) => a.reduce((s, v, k) => s + Math.abs(v - b[k]), 0);
    for (const p of probes)
      assert.ok(diff(p.at_corner.composite, p.at_corner.frame) <= 3, `corner ${JSON.stringify(p.at_corner)}`);
    assert.ok(inside.some((p) => diff(p.at_object.composite, p.at_object.frame) > 30),
      `the object's pixels look like the camera's: ${JSON.stringify(inside.slice(0, 3))}`);

    // The page's controls of issue 17: the shading control switches the renderer to hemisphere
    // shading, the material and refraction controls make the object glass showing the video
    // through it, and the location box sends the phone's place (the browser's geolocation, which
    // Playwright grants here) to arlightd, which answers with the sun (unknown until then).
    assert.equal(status.sun, 'unknown');
    await context.grantPermissions(['geolocation']);
    await context.setGeolocation({ latitude: 45.4371, longitude: 12.3326, accuracy: 10 });
    const before = await page.evaluate(() => window.arlight.status().frame_media_time);
    await page.evaluate(() => {
      for (const [id, value] of [['shading', 'hemisphere'], ['material', 'glass'], ['refraction', 'live'],
        ['colour', 'match']]) {
        const select = document.getElementById(id);
        select.value = value;
        select.dispatchEvent(new Event('change'));
      }
      const box = document.getElementById('use-location');
      box.checked = true;
      box.dispatchEvent(new Event('change'));
    });
    await page.waitForFunction(() => {
      const s = window.arlight.status();
      return s.shading === 'hemisphere' && s.material === 'glass' && s.refraction === 'live' &&
        s.colour === 'match' && s.sun !== 'unknown';
    }, null, { timeout: 30000 });
    // The glass (live refraction: the video frame copied and sampled through it) keeps rendering
    // (10 more video frames composited, no error shown).
    await page.waitForFunction((t) => window.arlight.status().frame_media_time > t + 5, before,
      { timeout: 30000 });
    assert.equal(await page.evaluate(() => document.getElementById('error').textContent), '');
    const lit = await page.evaluate(() => window.arlight.status());
    assert.equal(lit.geolocation, 'granted');
    assert.ok(['below-horizon', 'predicted', 'confirmed'].includes(lit.sun), lit.sun);
    assert.ok(Math.abs(Math.hypot(...lit.sun_direction) - 1) < 1e-3, `sun ${lit.sun_direction}`);
    assert.deepEqual(pageErrors, []);

    // A metallic-roughness material (issue 34): the page asks arlightd for the room's GGX chain
    // instead of the Phong maps, gets a whole one (128 -> 16) and renders with it, no error.
    assert.equal(lit.maps_requested, 'phong');
    assert.equal(lit.ggx_face, 0);
    await page.evaluate(() => {
      for (const [id, value] of [['shading', 'maps'], ['material', 'gold']]) {
        const select = document.getElementById(id);
        select.value = value;
        select.dispatchEvent(new Event('change'));
      }
    });
    await page.waitForFunction(() => window.arlight.status().ggx_face === 128, null, { timeout: 60000 });
    const gold = await page.evaluate(() => window.arlight.status());
    assert.equal(gold.material, 'gold');
    assert.equal(gold.maps_requested, 'ggx');
    // It keeps compositing (5 more video frames) with the chain, and shows no error.
    await page.waitForFunction((t) => window.arlight.status().frame_media_time > t + 2.5,
      gold.frame_media_time, { timeout: 30000 });
    assert.equal(await page.evaluate(() => window.arlight.status().last_error), '');
    assert.deepEqual(pageErrors, []);

    // A glTF's own materials: the textured tiled ball from the model menu, drawn "from the
    // model" (its two metallic-roughness materials and four textures, decoded on the page).
    await page.evaluate(() => {
      for (const [id, value] of [['model', 'tiles'], ['material', 'model']]) {
        const select = document.getElementById(id);
        select.value = value;
        select.dispatchEvent(new Event('change'));
      }
    });
    await page.waitForFunction(() => window.arlight.status().model === 'tiles', null, { timeout: 30000 });
    const tiles = await page.evaluate(() => window.arlight.status());
    assert.equal(tiles.material, 'model');
    assert.equal(tiles.model_materials, 2);
    assert.deepEqual(tiles.model_warnings, []);
    assert.equal(tiles.maps_requested, 'ggx');
    await page.waitForFunction((t) => window.arlight.status().frame_media_time > t + 2.5,
      tiles.frame_media_time, { timeout: 30000 });
    assert.equal(await page.evaluate(() => document.getElementById('error').textContent), '');
    assert.deepEqual(pageErrors, []);

    // A wrong token: the page says it was refused, and does not retry.
    const wrong = await context.newPage();
    await enableOrientationOverride(wrong);
    await overrideOrientation(wrong, sensorReadingFor(room.poses[0]));
    await wrong.goto(d.url.replace(/token=[^&]*/, 'token=not-the-token') + '&autostart=1');
    await wrong.waitForFunction(() => /Unauthorized/.test(window.arlight.status().last_error), null,
      { timeout: 20000 });
    assert.match(await wrong.textContent('#error'), /refused: Unauthorized/);
    assert.equal((await wrong.evaluate(() => window.arlight.status())).connected, false);
  } finally {
    await browser.close();
    await d.stop();
  }
  fs.rmSync(dir, { recursive: true, force: true });
});
