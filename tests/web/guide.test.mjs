// Unit tests for the capture guide's words (client/web/src/status_panel.js): arlightd's next view
// (LightingUpdate.next_view) turned into what the phone page tells the user, and its statement
// of the light. World frame: -Z ahead, +Y up; the azimuth atan2(x, -z) grows to the right.
import test from 'node:test';
import assert from 'node:assert/strict';

import { viewText, lightErrorText } from '../../client/web/src/status_panel.js';

const unit = (v) => { const n = Math.hypot(...v); return v.map((x) => x / n); };
const dir = (azimuthDeg, elevationDeg) => {
  const a = (azimuthDeg * Math.PI) / 180, e = (elevationDeg * Math.PI) / 180;
  return [Math.sin(a) * Math.cos(e), Math.sin(e), -Math.cos(a) * Math.cos(e)];
};

test('the next view in words: which way to turn, and by how much', () => {
  const ahead = [0, 0, -1];
  assert.equal(viewText(ahead, dir(90, 0)), 'turn right 90°');
  assert.equal(viewText(ahead, dir(-45, 0)), 'turn left 45°');
  assert.equal(viewText(ahead, dir(0, 40)), 'turn up 40°');
  assert.equal(viewText(ahead, dir(-60, -30)), 'turn left 60° and down 30°');
  // Across the back: the shorter way round.
  assert.equal(viewText(dir(170, 0), dir(-170, 0)), 'turn right 20°');
  assert.equal(viewText(ahead, dir(5, 3)), 'hold here');
  assert.equal(viewText(ahead, unit([0.1, 1, 0])), 'look straight up');
  assert.equal(viewText(ahead, unit([0, -1, 0.05])), 'look straight down');
});

test("the light's statement: good to ±N %, unknown, or none", () => {
  assert.equal(lightErrorText(0.043), 'good to ±4 %');
  assert.equal(lightErrorText(0.002), 'good to ±1 %');
  assert.equal(lightErrorText(1.25), 'good to ±125 %');
  assert.equal(lightErrorText(10), 'not known yet');
  assert.equal(lightErrorText(0), '');  // not stated (arlightd --fill none)
});
