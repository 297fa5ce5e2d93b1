// The status panel beside the view (#status, #coverage): the connection, the frames, the
// lighting, the capture guide, the marker and the speed, in words, once a second.
import { quatRotateVector } from './orientation.js';
import { clientStatus, joinUrl, report, state } from './status.js';

const $ = (id) => document.getElementById(id);

// What the fixed guide's row asks of the user, in words (a server that states no next view).
function rowText(elevation) {
  if (elevation === null) return 'all round: done';
  if (elevation > 75) return 'look straight up';
  if (elevation < -75) return 'look straight down';
  return `sweep round at ${Math.abs(elevation).toFixed(0)}° ${elevation >= 0 ? 'up' : 'down'}`;
}

const kDeg = 180 / Math.PI;
const elevationOf = (d) => Math.asin(Math.max(-1, Math.min(1, d[1]))) * kDeg;

/**
 * arlightd's next view (issue 48 §2) in words, from a camera looking along `forward` (both unit,
 * world frame): "look straight up", "hold here" once within 12°, otherwise the turn — right is
 * the azimuth atan2(x, -z) growing (common/CONVENTIONS.md), up the elevation.
 */
export function viewText(forward, target) {
  const el = elevationOf(target);
  const cos = forward[0] * target[0] + forward[1] * target[1] + forward[2] * target[2];
  if (Math.acos(Math.max(-1, Math.min(1, cos))) * kDeg < 12) return 'hold here';
  if (el > 75) return 'look straight up';
  if (el < -75) return 'look straight down';
  let turn = (Math.atan2(target[0], -target[2]) - Math.atan2(forward[0], -forward[2])) * kDeg;
  turn = ((turn + 540) % 360) - 180;
  const tilt = el - elevationOf(forward);
  const parts = [];
  if (Math.abs(turn) >= 10) parts.push(`${turn > 0 ? 'right' : 'left'} ${Math.abs(turn).toFixed(0)}°`);
  if (Math.abs(tilt) >= 10) parts.push(`${tilt > 0 ? 'up' : 'down'} ${Math.abs(tilt).toFixed(0)}°`);
  return parts.length ? `turn ${parts.join(' and ')}` : 'hold here';
}

/** arlightd's statement of the light in words: "good to ±N %", "not known yet" or '' (none). */
export function lightErrorText(lightError) {
  if (!(lightError > 0)) return '';
  if (lightError >= 10) return 'not known yet';
  return `good to ±${Math.max(1, Math.round(lightError * 100))} %`;
}

/**
 * /three.html watching this session (issue 35): the session's id with this device's id and
 * token, in the fragment (never sent to a server); '' before the session has an id.
 */
export function watchUrl(sessionId, { device, token }) {
  if (!sessionId) return '';
  const fragment = new URLSearchParams({ session: sessionId, device: device || '', token: token || '' });
  return `three.html#${fragment}`;
}

/** What a contributor's page says of its registration (status().registration). */
export function registrationText(registration) {
  if (registration === 2) return 'registered: capturing into the shared map';
  if (registration === 1) return 'registering: point the camera at what the other phone has captured';
  return '';
}

/**
 * The panel now; `coverage` the CoverageView, `q` the orientation of the frame shown, `params`
 * the page's (for the "watch this room" link).
 */
export function updatePanel(coverage, q, params) {
  const lighting = clientStatus();
  const forward = quatRotateVector(q, [0, 0, -1]);
  if (lighting.next_view) {
    // arlightd's next view: where the light is least known and a look would tell most.
    state.guideElevation = elevationOf(lighting.next_view);
    state.guideText = viewText(forward, lighting.next_view);
    state.guideView = lighting.next_view;
    coverage.draw(forward, null, lighting.next_view);
  } else {
    // No proposal: a server that states none (the fixed ceiling-first rows), or nothing left to
    // gain. A session continued from another page (#session=ID) may be seen all round already.
    const done = lighting.coverage >= 0.99 || (lighting.light_error > 0 && lighting.light_error < 10);
    state.guideElevation = done ? null : coverage.nextElevation();
    state.guideText = rowText(state.guideElevation);
    state.guideView = null;
    coverage.draw(forward, state.guideElevation);
  }
  $('s-guide').textContent = state.guideText;
  $('s-connection').textContent = state.connected ? `session ${state.sessionId.slice(0, 8)}` : 'connecting…';
  $('s-frames').textContent = `${state.framesSent} sent, ${lighting.frames_processed} in the map`;
  const stated = lightErrorText(lighting.light_error);
  $('s-lighting').textContent = `${lighting.lighting}, ${lighting.map_sets} map sets, ${(lighting.coverage * 100).toFixed(0)} % seen` +
    (lighting.estimated > 0 ? `, ${(lighting.estimated * 100).toFixed(0)} % estimated` : '') +
    (stated ? `; light ${stated}` : '');
  $('s-marker').textContent = `${state.trackStatus}, ${state.trackedFrames} frames`;
  const link = $('s-watch');
  const url = watchUrl(state.sessionId, params);
  if (link && url && link.getAttribute('href') !== url) {
    link.setAttribute('href', url);
    link.textContent = 'open in three.js (another device)';
    // The same link as a QR code for a second phone, drawn by arlightd (libqrencode).
    const qr = $('s-watch-qr');
    qr.src = `qr.svg?three=${url.slice(url.indexOf('#') + 1)}`;
    qr.hidden = false;
  }
  const status = lighting;
  const joinLink = $('s-join');
  if (joinLink && status.joining) {
    joinLink.textContent = registrationText(status.registration) || 'joining…';
    joinLink.removeAttribute('href');
  } else if (joinLink) {
    const join = joinUrl(state.sessionId, status.join_token);
    if (join && joinLink.getAttribute('href') !== join) {
      joinLink.setAttribute('href', join);
      joinLink.textContent = 'open on another phone';
      const qr = $('s-join-qr');
      qr.src = `qr.svg?join=${join.slice(join.indexOf('#') + 1)}`;
      qr.hidden = false;
    }
  }
  const p = report();
  $('s-speed').textContent =
      `${state.fps.toFixed(1)} fps, ${state.renderMs.toFixed(1)} ms a frame, latency ${
          p.latency_p50_ms.toFixed(0)} ms` +
      (p.shadow_lights > 0 ? `, ${p.shadow_lights} shadow lights` : '');
}
