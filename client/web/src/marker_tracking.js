// The page's side of marker tracking. Its worker (marker_worker.js, opencv.js) gets one frame at
// a time, the newest offered winning: every frame while the marker is tracked, a few a second
// while it is not (a search costs as much as a frame's tracking, and the rest of the page needs
// the cores). A pose found goes into the C++ pose filter (WebClient.markerSeen), which stands the
// object on the marker; every view's corners, a refused pose's too, refine the focal length
// (intrinsics.js). Started first thing on Start, before the module and the camera: opencv.js
// takes seconds to load.
import { focalEstimate } from './intrinsics.js';
import { showError, state } from './status.js';

const kSearchIntervalMs = 250;
const kRegisterHoldMs = 500;
const kStuckMs = 2000;
const kTracksKept = 1000;  // state.tracks
const kViewsKept = 64;     // the focal length's views: the newest

export class MarkerTracking {
  /** @param {{id: number, size: number, dictionary: string}} marker params.js's */
  constructor(marker) {
    this.marker = marker;
    this.ready = false;       // opencv.js loaded
    this.busy = false;
    this.next = 0;
    this.frames = new Map();  // what the page knew of each frame in the worker
    this.found = false;       // in the last result
    this.lastOffer = -Infinity;
    this.lastFoundAt = -Infinity;  // performance.now() of the last result that found it
    this.client = null;       // set by follow()
    this.onFocal = null;
    this.views = [];          // the newest kViewsKept views' corners
    this.viewsSeen = 0;
    this.refineAt = 8;        // views seen; doubling, then every 64
    this.worker = new Worker('marker_worker.js');
    this.worker.onmessage = ({ data }) => {
      if (data.type === 'ready') {
        this.ready = true;
        if (this.client) this.nowReady();
        return;
      }
      const frame = this.frames.get(data.id);
      this.frames.delete(data.id);
      this.busy = false;
      if (data.type === 'result') this.found = Boolean(data.found && !data.found.refused);
      if (this.found) this.lastFoundAt = performance.now();
      try {
        if (data.type === 'result' && frame) this.result(data.found, frame, data.ms);
        else if (data.type === 'error') this.failed(data.message);
      } finally {
        frame?.resolve(data.type === 'result' && this.found);
      }
    };
    this.worker.onerror = (e) => this.failed(e.message || 'the tracking worker failed');
    this.worker.postMessage({ type: 'marker', ...marker });
  }

  /**
   * Once the renderer exists: the results go into `client`'s pose filter, and a focal length the
   * views are sure of to `onFocal(f)` (pixels), which gives it to the client. Before offer().
   */
  follow(client, onFocal) {
    this.client = client;
    this.onFocal = onFocal;
    if (this.ready) this.nowReady();
  }

  // Whether the page shows each frame with its own pose: the marker was found in the last
  // result, or lost for less than kRegisterHoldMs (a blurred frame, a hand: those frames are
  // not shown rather than shown off the marker).
  get registering() {
    const now = performance.now();
    // A worker that has not answered for kStuckMs (it failed, or the machine stalls): every
    // frame shows again rather than none.
    if (!this.ready || (this.busy && now - this.lastOffer > kStuckMs)) return false;
    return this.found || now - this.lastFoundAt < kRegisterHoldMs;
  }

  // The frame that reached the page (`take` gives a transferable copy of it), with what it knows
  // of it ({t, q, mediaTime}). Returns a promise that settles once the worker's result for it is
  // in the pose filter (true: the marker was found), or null when the frame is not taken: the
  // worker busy or still loading opencv.js, or a search too soon after the last.
  offer(take, k, frame) {
    if (!this.ready || this.busy) return null;
    // The first frame the tracker could take: the frames before it were never offered (on a
    // warm cache opencv.js is ready before the camera's first frames reach the page).
    state.trackerReadyMediaTime ??= frame.mediaTime;
    const now = performance.now();
    if (!this.found && now - this.lastOffer < kSearchIntervalMs) return null;
    this.lastOffer = now;
    this.busy = true;
    const id = ++this.next;
    const done = new Promise((resolve) => this.frames.set(id, { ...frame, resolve }));
    take().then((image) => this.worker.postMessage({ type: 'frame', id, image, k }, [image]), () => {
      this.frames.get(id)?.resolve(false);
      this.frames.delete(id);
      this.busy = false;
    });
    return done;
  }

  nowReady() {
    state.tracker = 'ready';
  }

  failed(message) {
    if (!this.ready) state.tracker = 'failed';
    showError(`tracking: ${message}`);
  }

  // `found`: marker.js's detect() result for `frame`; `ms`: the worker's time for it.
  result(found, frame, ms) {
    state.trackMs = ms;
    if (!found || found.refused) {
      const { id } = this.marker;
      state.trackStatus = found ? `marker ${id} refused: ${found.refused}` : `marker ${id} not in view`;
      // A refused pose's corners still tell the focal length (a wrong one is often why).
      if (found) this.refineFocal(found.corners);
      return;
    }
    const pose = this.client.markerSeen(frame.t, ...found.rvec, ...found.tvec, ...frame.q);
    ++state.trackedFrames;
    state.trackStatus = 'tracked';
    state.tracking = 'marker';
    state.tracks.push({ media_time: frame.mediaTime, raw: pose.raw, smoothed: pose.smoothed, velocity: pose.velocity,
      reprojection_px: found.reprojectionPx });
    if (state.tracks.length > kTracksKept) state.tracks.shift();
    this.refineFocal(found.corners);
  }

  // One more view's corners; every so often the focal length from the views kept.
  refineFocal(corners) {
    this.views.push(corners);
    if (this.views.length > kViewsKept) this.views.shift();
    if (++this.viewsSeen < this.refineAt) return;
    this.refineAt = Math.min(2 * this.refineAt, this.refineAt + 64);
    const k = this.client.camera();
    const estimate = focalEstimate(this.views, k.cx, k.cy);
    if (!estimate) return;
    // Only a well-determined focal length (1 % standard error), and only a change it is sure of:
    // views of a marker seen nearly square-on say little, and a worse focal length moves the
    // object by as many per cent of its distance.
    const { focal: f, relativeError } = estimate;
    state.focalError = relativeError;
    if (!(relativeError < 0.01) || !(f > 0.5 * k.fx && f < 2 * k.fx) ||
        Math.abs(f / k.fx - 1) < Math.max(0.005, 2 * relativeError)) return;
    this.onFocal(f);
    state.intrinsics = 'refined';
    state.refinedMediaTime = state.frameMediaTime;
  }
}
