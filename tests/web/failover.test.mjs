// No frame lost in a fail-over, for the phone page (issue 36 §5, PROTOCOL.md "Fail-over"): a
// real arlightd serving the page is killed (SIGKILL) while frames it has not checkpointed are
// in it; another arlightd on the same data folder and web port takes the session over once its
// lease expires, the page resumes it, sends the frames the checkpoint lacks again, and the
// session ends up with every frame the page sent, each once.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';

import { launchChromium } from './harness.mjs';
import { simulateRoom, startDaemon, playRoom } from './phone_session.mjs';

const BIN = process.env.ARLIGHT_BIN;
const SOURCE = process.env.ARLIGHT_SOURCE_DIR;
const TOKEN = 'web-test-token-0123456789';

test('a killed daemon\'s session resumes on another with every frame the page sent', { timeout: 240000 }, async () => {
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'arlight-web-failover-'));
  let first, second, browser;
  try {
    const room = simulateRoom({ bin: BIN, probe: path.join(SOURCE, 'data/probes/venice.exr'), dir,
      frames: 40, fps: 4, width: 320, height: 240, seed: 5 });
    const daemonDir = path.join(dir, 'daemon');
    const webRoot = path.join(BIN, 'web');
    first = await startDaemon({ bin: BIN, dir: daemonDir, webRoot, token: TOKEN });
    let page;
    ({ browser, page } = await launchChromium({ y4m: room.y4m }));
    let killedWith = null;  // the page's status when its daemon died
    await playRoom(page, first.url, room, {
      onTick: async (s) => {
        // A checkpoint exists (so the session can be resumed) and three or more frames sent
        // since are in no checkpoint: kill the daemon now, and start the one taking over.
        if (killedWith || !(s.saved_sequence > 0 && s.frames_kept >= 3)) return;
        killedWith = s;
        await first.kill();
        second = await startDaemon({ bin: BIN, dir: daemonDir, webRoot, token: TOKEN, webPort: first.web });
      },
    });
    assert.ok(killedWith, 'the page never had frames outside a checkpoint');
    // The page resumed on the second daemon and has had an answer for its last frame.
    const sent = await page.evaluate(() => window.arlight.sent());
    const last = sent.at(-1).sequence;
    await page.waitForFunction((seq) => {
      const s = window.arlight.status();
      return s.session_resumed && s.last_sequence >= seq;
    }, last, { timeout: 30000 });
    const status = await page.evaluate(() => window.arlight.status());
    console.log(`killed with ${killedWith.frames_kept} frames after checkpoint ${killedWith.saved_sequence}; ` +
      `resumed at ${status.session_last_sequence}, ${status.frames_resent} sent again; ${last} frames sent in all`);
    assert.ok(status.frames_resent >= 1, `no frame sent again: ${JSON.stringify(status)}`);
    assert.ok(status.session_last_sequence < last);
    // Every frame the page made, once: those in the checkpoint, those sent again, and the rest
    // (the page numbers its frames 1, 2, ...: as many received as the newest one's number).
    const sessions = await second.adminGet('/sessions');
    const session = sessions.find((x) => x.id === status.session_id);
    assert.ok(session, `the second daemon has no session ${status.session_id}: ${JSON.stringify(sessions)}`);
    assert.ok(session.last_sequence >= last, JSON.stringify(session));
    assert.equal(session.frames_received, session.last_sequence, JSON.stringify(session));
    assert.equal(session.frames_duplicate, 0);
  } finally {
    if (browser) await browser.close();
    if (second) await second.stop();
    if (first) await first.kill().catch(() => {});
    fs.rmSync(dir, { recursive: true, force: true });
  }
});
