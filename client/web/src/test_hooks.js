// window.arlight: what the page is doing, for its tests and for people wondering whether the
// object is where they think. The page itself reads none of it (the status panel reads
// status.js). The probe composites a snapshot of the video the page's way and reads it back.
import { snapshotFrame } from './camera.js';
import { report, state } from './status.js';

const kRecentFrames = 8;  // the frames shown whose orientations the probe can look up
const kDrawnKept = 2000;  // state.drawn: a minute at 30 fps

let probeComposite = () => null;  // until the page composites (enableProbe)

/** Defines window.arlight (at the page's load: status() answers before Start). */
export function installHooks() {
  window.arlight = {
    // The object's centre in the canvas, and at that pixel, at the canvas corner farthest from it
    // and on the floor just in front of it (its contact shadow; null before it stands on the
    // marker), the composite's RGB beside the camera frame's RGB it was drawn over.
    probe() {
      return probeComposite();
    },
    // The recent marker poses: {media_time (the frame's, as the camera stamped it), raw, smoothed
    // (the camera's pose in the marker frame: position in metres, orientation [w, x, y, z]),
    // velocity (the pose filter's, m/s in the marker frame), reprojection_px}.
    tracks() {
      return state.tracks.slice();
    },
    // The recent composites, one per camera frame the page showed: {media_time (the frame's),
    // centre (the object's centre in the canvas, pixels, row 0 at the top; null without an
    // object), on_marker (placed by the marker's pose, not the preview), after_ms (from the
    // frame being taken to its composite)}.
    drawn() {
      return state.drawn.slice();
    },
    // The recent frames sent to arlightd: {media_time (the frame's), orientation (camera -> world,
    // [w, x, y, z], as sent with it)}.
    sent() {
      return state.sent.slice();
    },
    // status.js's report().
    status() {
      return report();
    },
  };
}

/**
 * The probe, once the page composites: one snapshot of the video's current frame drawn for
 * reference and composited the page's way with the orientation that frame came with, and the
 * canvas read back. (The video may be a frame ahead of the page's last frame callback: then its
 * orientation is waited for.) Returns frameShown(t, q, mediaTime), for every frame the page shows.
 */
export function enableProbe({ video, grabber, canvas, client, compositor, width: w, height: h }) {
  const readBack = document.createElement('canvas');
  readBack.width = w;
  readBack.height = h;
  const readCtx = readBack.getContext('2d', { willReadFrequently: true });
  let shown = { t: 0, q: [1, 0, 0, 0], mediaTime: undefined };
  const recent = new Map();  // media time -> {t, q, mediaTime}, of the last frames shown
  probeComposite = async () => {
    let image;
    let mediaTime = shown.mediaTime;
    for (let attempt = 0; ; ++attempt) {
      image = await snapshotFrame(video);
      // VideoFrame timestamps are the media times in microseconds; a bitmap has none.
      if (image.timestamp === undefined) break;
      mediaTime = image.timestamp / 1e6;
      if (recent.has(mediaTime) || attempt === 10) break;
      image.close();
      await new Promise((r) => setTimeout(r, 20));
    }
    const { t, q } = recent.get(mediaTime) || shown;
    let frame;
    try {
      grabber.ctx.drawImage(image, 0, 0, w, h);
      frame = grabber.ctx.getImageData(0, 0, w, h).data;
      await compositor.composite(t, q, image, false);
    } finally {
      image.close();
    }
    const centre = client.objectPixel();
    if (!centre) return null;
    readCtx.drawImage(canvas, 0, 0);
    const px = (x, y) => {
      const xi = Math.min(w - 1, Math.max(0, Math.round(x)));
      const yi = Math.min(h - 1, Math.max(0, Math.round(y)));
      const c = readCtx.getImageData(xi, yi, 1, 1).data;
      const f = frame.subarray(4 * (yi * w + xi));
      return { x: xi, y: yi, composite: [c[0], c[1], c[2]], frame: [f[0], f[1], f[2]] };
    };
    const corner = [centre[0] < w / 2 ? w - 2 : 1, centre[1] < h / 2 ? h - 2 : 1];
    const floor = client.floorPixel();  // in front of the object: its contact shadow
    const last = state.tracks[state.tracks.length - 1];
    return {
      centre,
      at_object: px(centre[0], centre[1]),
      at_corner: px(corner[0], corner[1]),
      at_floor: floor ? px(floor[0], floor[1]) : null,
      shadow_lights: client.status().shadow_lights,
      width: w,
      height: h,
      media_time: mediaTime,
      tracked_media_time: last ? last.media_time : null
    };
  };
  return (t, q, mediaTime) => {
    shown = { t, q, mediaTime };
    recent.set(mediaTime, shown);
    if (recent.size > kRecentFrames) recent.delete(recent.keys().next().value);
  };
}

/**
 * Keeps what the composite of the frame at `mediaTime`, taken at `t` (s, performance.now()'s
 * clock), drew (window.arlight.drawn()).
 */
export function recordDrawn(client, mediaTime, t) {
  state.drawn.push({ media_time: mediaTime, centre: client.objectPixel(), on_marker: client.placedOnMarker(),
    after_ms: performance.now() - 1000 * t });
  if (state.drawn.length > kDrawnKept) state.drawn.shift();
}
