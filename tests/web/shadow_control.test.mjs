// The page's soft shadow and its frame-rate control (tutorial §6, §6.4) end to end in headless
// Chromium: arlightd holds a session that has seen all of lab (a replayed sweep, so its map set
// holds the lamps), the page continues that session (&session=) looking at the marker, and
// blends the hard shadows of the map's light clusters into the floor. At an easy target frame
// rate the control adds lights while frames stay under it; at one no frame can meet it cuts
// them to one. Run by ctest (tests/web/web_tests.cmake).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';

import { launchChromium } from './harness.mjs';
import { simulateRoom, startDaemon, playRoom } from './phone_session.mjs';

const BIN = process.env.ARLIGHT_BIN;
const SOURCE = process.env.ARLIGHT_SOURCE_DIR;
const TOKEN = 'web-shadow-token-0123456789';

test('the page blends the room\'s light clusters into the shadow and holds its frame rate', { timeout: 300000 }, async () => {
  assert.ok(BIN && SOURCE, 'ARLIGHT_BIN and ARLIGHT_SOURCE_DIR must be set (ctest does)');
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'arlight-web-shadow-'));
  const probe = path.join(SOURCE, 'data/probes/lab.exr');
  execFileSync(path.join(BIN, 'arlight-sim'), ['--env', probe, '--out', path.join(dir, 'sweep'),
    '--frames', '120', '--size', '320x240', '--seed', '11'], { stdio: 'pipe' });
  const room = simulateRoom({
    bin: BIN, probe, dir, frames: 24, fps: 2, seed: 5,
    extraArgs: ['--trajectory', 'orbit', '--marker', '7,0.2'],
  });
  const d = await startDaemon({ bin: BIN, dir: path.join(dir, 'daemon'), webRoot: path.join(BIN, 'web'), token: TOKEN });
  try {
    const port = /listening on 127\.0\.0\.1:(\d+)/.exec(d.banner)[1];
    execFileSync(path.join(BIN, 'arlight-replay'), ['--server', `127.0.0.1:${port}`, '--token', TOKEN,
      '--device', 'phone', '--recording', path.join(dir, 'sweep'), '--maps', '', '--out', path.join(dir, 'replay')], { stdio: 'pipe' });
    const session = JSON.parse(fs.readFileSync(path.join(dir, 'replay', 'replay.json'))).session_id;
    assert.ok(session, 'arlight-replay reported no session');

    const run = async (fps) => {
      const { browser, page } = await launchChromium({ y4m: room.y4m });
      const pageErrors = [];
      page.on('pageerror', (e) => pageErrors.push(e.message));
      const seen = [];  // per poll on the marker under a map set: [hard shadows drawn, budget]
      try {
        await playRoom(page, d.url, room, {
          fragment: `&marker=7,0.2&session=${session}&fps=${fps}`,
          onTick: async (s) => {
            if (s.tracking === 'marker' && s.lighting === 'maps') seen.push([s.shadow_lights, s.shadow_light_budget]);
          },
        });
        const status = await page.evaluate(() => window.arlight.status());
        assert.deepEqual(pageErrors, []);
        assert.equal(status.last_error, '');
        assert.equal(status.target_fps, fps);
        console.log(`target ${fps} fps: ${seen.length} polls on the marker under maps; hard shadows ` +
          `${Math.min(...seen.map((v) => v[0]))}-${Math.max(...seen.map((v) => v[0]))}, budget ` +
          `${seen.length ? seen[0][1] : '-'} -> ${status.shadow_light_budget}; render ${status.render_ms.toFixed(1)} ms`);
        return { seen, status };
      } finally {
        await browser.close();
      }
    };

    // 5 fps: every frame is far under 200 ms, so the budget grows from its start (4), and the
    // lamps' clusters are drawn.
    const easy = await run(5);
    assert.ok(easy.seen.length >= 10, `only ${easy.seen.length} polls on the marker with maps`);
    assert.ok(Math.max(...easy.seen.map((v) => v[0])) >= 2, 'never more than one hard shadow');
    assert.ok(easy.status.shadow_light_budget > 4, `the budget stayed at ${easy.status.shadow_light_budget}`);
    for (const [drawn, budget] of easy.seen) assert.ok(drawn <= budget, `${drawn} drawn over a budget of ${budget}`);
    // 1000 fps: no frame takes under 1 ms, so after two late frames the count is cut, down to one.
    const hard = await run(1000);
    assert.equal(hard.status.shadow_light_budget, 1);
    assert.ok(hard.seen.length >= 10 && hard.seen.slice(-4).every(([drawn]) => drawn <= 1),
      `still drawing ${JSON.stringify(hard.seen.slice(-4))}`);
  } finally {
    await d.stop();
  }
  fs.rmSync(dir, { recursive: true, force: true });
});
