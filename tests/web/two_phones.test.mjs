// Two phones, one room (issue 49 §1) in real headless Chromium (SwiftShader's WebGL2), against a
// real arlightd over wss on loopback. The first phone's page sees the first half of a room sweep
// (its fake camera plays that half, over and over) and shows its "capture with another phone"
// link and QR code; a second phone — another Chromium, its fake camera playing the whole sweep,
// its orientation sensor 130 degrees off in heading as a second phone's own yaw origin is — opens
// that link, is registered with the first phone's map and captures into it: the shared map grows
// past what the first phone can see, on both pages. Each page's sensor reports the true pose of
// the very frame it shows (phone_session.mjs, frameSyncedSensor). A third device, the first
// page's watch link in another tab, follows the shared session. The second phone and the third
// device open their links on another arlightd of the same data folder (a fleet's other daemon,
// issue 49 §2): it sends both to the session's (Error{Moved} with its web port).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';

import { launchChromium } from './harness.mjs';
import { frameSyncedSensor, simulateRoom, stampFrameIndices, startDaemon } from './phone_session.mjs';

const BIN = process.env.ARLIGHT_BIN;
const SOURCE = process.env.ARLIGHT_SOURCE_DIR;
const TOKEN = 'web-two-phones-token-0123456789';
const kHeadingDeg = 130;

// The first `count` frames of a stamped room: its Y4M cut there, its poses with it.
function firstFrames(room, count, dir) {
  const bytes = fs.readFileSync(room.y4m);
  const headerEnd = bytes.indexOf(0x0a) + 1;
  const frameBytes = 6 + (room.width * room.height * 3) / 2;
  const y4m = path.join(dir, 'first.y4m');
  fs.writeFileSync(y4m, bytes.subarray(0, headerEnd + count * frameBytes));
  return { ...room, y4m, frames: count, poses: room.poses.slice(0, count) };
}

// The room as a phone whose heading origin is `deg` off sees it: each pose turned about +Y.
function turnedHeading(room, deg) {
  const h = (-deg * Math.PI) / 360;  // half of -deg, in radians
  const [tw, ty] = [Math.cos(h), Math.sin(h)];
  const turn = ([w, x, y, z]) => [tw * w - ty * y, tw * x + ty * z, tw * y + ty * w, tw * z - ty * x];
  return { ...room, poses: room.poses.map((p) => ({ ...p, orientation: turn(p.orientation) })) };
}

const status = (page) => page.evaluate(() => window.arlight.status());

test('a second phone joins by the first one\'s link, is registered and captures into its session', { timeout: 300000 }, async () => {
  assert.ok(BIN && SOURCE, 'ARLIGHT_BIN and ARLIGHT_SOURCE_DIR must be set (ctest does)');
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'arlight-web-two-phones-'));
  const room = simulateRoom({ bin: BIN, probe: path.join(SOURCE, 'data/probes/venice.exr'), dir, frames: 48, fps: 4 });
  stampFrameIndices(room);
  const half = firstFrames(room, 20, dir);
  const d = await startDaemon({ bin: BIN, dir: path.join(dir, 'daemon'), webRoot: path.join(BIN, 'web'), token: TOKEN });
  // The fleet's other daemon: the same data folder (and certificate), its own ports.
  const other = await startDaemon({ bin: BIN, dir: path.join(dir, 'daemon'), webRoot: path.join(BIN, 'web'), token: TOKEN });
  const otherOrigin = new URL(other.url).origin;
  const first = await launchChromium({ y4m: half.y4m });
  let second = null;
  try {
    const errors = [];
    first.page.on('pageerror', (e) => errors.push(`first: ${e.message}`));
    await frameSyncedSensor(first.page, half);
    await first.page.goto(`${d.url}&autostart=1&fov=${room.vfovDeg}`);
    // Its half of the room captured, and a join link from arlightd.
    await first.page.waitForFunction(() => {
      const s = window.arlight.status();
      return s.frames_processed >= 30 && s.join_url !== '';
    }, null, { timeout: 90000 });
    const a = await status(first.page);
    assert.equal(a.joining, false);
    assert.equal(a.registration, 0);
    assert.ok(a.coverage < 0.8, `the first half alone covers ${a.coverage}`);
    const href = await first.page.$eval('#s-join', (e) => e.getAttribute('href'));
    assert.equal(href, a.join_url);
    assert.match(href, /^index\.html#device=phone-[0-9a-f]{6}&token=[0-9a-f]{32}&join=[0-9a-f]{32}$/);
    assert.ok(href.endsWith(`join=${a.session_id}`), href);
    const qr = await first.page.$eval('#s-join-qr', (img) => ({ src: img.getAttribute('src'), width: img.naturalWidth, hidden: img.hidden }));
    assert.equal(qr.src, `qr.svg?join=${href.slice(href.indexOf('#') + 1)}`);
    assert.ok(qr.width > 0 && !qr.hidden, JSON.stringify(qr));

    // The second phone opens the link.
    second = await launchChromium({ y4m: room.y4m });
    second.page.on('pageerror', (e) => errors.push(`second: ${e.message}`));
    await frameSyncedSensor(second.page, turnedHeading(room, kHeadingDeg));
    await second.page.goto(`${otherOrigin}/${href.slice(href.indexOf('#'))}&autostart=1&fov=${room.vfovDeg}`);
    await second.page.waitForFunction(() => window.arlight.status().registration === 2, null, { timeout: 90000 })
      .catch(async (e) => {
        const s = await status(second.page);
        throw new Error(`${e.message}; the second phone: connected ${s.connected}, registration ${s.registration}, ` +
          `last_error '${s.last_error}', moved_to '${s.moved_to}', frames_sent ${s.frames_sent}\n` +
          `the other daemon's log:\n${other.log().slice(-2000)}\nthe session's daemon's log:\n${d.log().slice(-2000)}`);
      });
    await second.page.waitForFunction((c) => window.arlight.status().coverage > c + 0.15, a.coverage, { timeout: 90000 });
    const b = await status(second.page);
    assert.equal(b.joining, true);
    assert.equal(b.session_id, a.session_id);
    assert.equal(b.last_error, '');
    assert.equal(b.moved_to, `127.0.0.1:${d.web}`, 'the other daemon did not send it on');
    assert.match(await second.page.$eval('#s-join', (e) => e.textContent), /^registered/);
    // The first phone sees the shared map grow too (its own frames' updates carry it), and the
    // second gets the session's map sets.
    await first.page.waitForFunction((c) => window.arlight.status().coverage > c + 0.15, a.coverage, { timeout: 60000 });
    await second.page.waitForFunction(() => window.arlight.status().map_sets >= 1, null, { timeout: 60000 });
    const sessions = await d.adminGet('/sessions');
    const listed = (sessions.sessions || sessions).find((s) => s.id === a.session_id);
    assert.ok(listed, JSON.stringify(sessions));
    assert.equal(listed.contributors, 1);
    // A third device watches (issue 49 §3): the first page's "watch this room" link, opened in
    // another tab, is a three.js page that follows the shared session as its phones capture.
    const watchHref = await first.page.$eval('#s-watch', (e) => e.getAttribute('href'));
    assert.ok(watchHref.startsWith(`three.html#session=${a.session_id}&`), watchHref);
    const third = await first.context.newPage();
    third.on('pageerror', (e) => errors.push(`third: ${e.message}`));
    await third.goto(`${otherOrigin}/${watchHref}`);
    await third.waitForFunction(() => {
      const s = window.arlightThree && window.arlightThree.status();
      return s && s.watching && s.updates >= 2;
    }, null, { timeout: 90000 });
    const w = await third.evaluate(() => window.arlightThree.status());
    assert.equal(w.session_id, a.session_id);
    assert.equal(w.last_error, '');
    const watched = (await d.adminGet('/sessions'));
    const now = (watched.sessions || watched).find((s) => s.id === a.session_id);
    assert.equal(now.watchers, 1, JSON.stringify(now));
    assert.equal(now.contributors, 1, JSON.stringify(now));
    const elsewhere = await other.adminGet('/sessions');
    assert.equal((elsewhere.sessions || elsewhere).length, 0, JSON.stringify(elsewhere));
    const metrics = await (await other.adminFetch('/metrics')).text();
    assert.match(metrics, /^arlight_sessions_redirected_total 2$/m);
    await third.close();
    console.log(`two phones: the first alone ${(a.coverage * 100).toFixed(0)} %, together ${(b.coverage * 100).toFixed(0)} %`);
    assert.deepEqual(errors, []);
  } finally {
    if (second) await second.browser.close();
    await first.browser.close();
    await d.stop();
    await other.stop();
  }
});
