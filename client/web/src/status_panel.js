// The status panel beside the view (#status, #coverage): the connection, the frames, the
// lighting, the capture guide, the marker and the speed, in words, once a second.
import { quatRotateVector } from './orientation.js';
import { clientStatus, report, state } from './status.js';

const $ = (id) => document.getElementById(id);

// What the guide's row asks of the user, in words.
function guideText(elevation) {
  if (elevation === null) return 'all round: done';
  if (elevation > 75) return 'look straight up';
  if (elevation < -75) return 'look straight down';
  return `sweep round at ${Math.abs(elevation).toFixed(0)}° ${elevation >= 0 ? 'up' : 'down'}`;
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

/**
 * The panel now; `coverage` the CoverageView, `q` the orientation of the frame shown, `params`
 * the page's (for the "watch this room" link).
 */
export function updatePanel(coverage, q, params) {
  const lighting = clientStatus();
  // A session continued from another page (#session=ID) may be seen all round already.
  state.guideElevation = lighting.coverage >= 0.99 ? null : coverage.nextElevation();
  coverage.draw(quatRotateVector(q, [0, 0, -1]), state.guideElevation);
  $('s-guide').textContent = guideText(state.guideElevation);
  $('s-connection').textContent = state.connected ? `session ${state.sessionId.slice(0, 8)}` : 'connecting…';
  $('s-frames').textContent = `${state.framesSent} sent, ${lighting.frames_processed} in the map`;
  $('s-lighting').textContent = `${lighting.lighting}, ${lighting.map_sets} map sets, ${(lighting.coverage * 100).toFixed(0)} % seen` +
    (lighting.estimated > 0 ? `, ${(lighting.estimated * 100).toFixed(0)} % estimated` : '');
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
  const p = report();
  $('s-speed').textContent =
      `${state.fps.toFixed(1)} fps, ${state.renderMs.toFixed(1)} ms a frame, latency ${
          p.latency_p50_ms.toFixed(0)} ms` +
      (p.shadow_lights > 0 ? `, ${p.shadow_lights} shadow lights` : '');
}
