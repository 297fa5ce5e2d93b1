/**
 * @file The phone camera for arlight's browser client: open the rear camera with getUserMedia,
 * try to lock its exposure, and grab the newest frame as RGBA pixels or as a JPEG.
 *
 * Plain ES module, no dependencies; runs in the page (a `<video>` element is needed, so not in a
 * worker). getUserMedia needs a secure context: https (arlightd serves its self-signed
 * certificate) or http://localhost / http://127.0.0.1.
 *
 * ## Errors
 *
 * `openCamera` rejects with a subclass of {@link CameraError}, each with its own `name` and a
 * stable `code`, and the browser's DOMException (if any) as `cause`:
 *
 * - {@link InsecureContextError} `insecure-context`: not a secure context (plain `http://` to a
 *   LAN address)
 * - {@link CameraUnsupportedError} `unsupported`: no `navigator.mediaDevices.getUserMedia`
 * - {@link CameraPermissionError} `permission-denied`: NotAllowedError / SecurityError, the user
 *   or a permissions policy refused
 * - {@link CameraNotFoundError} `not-found`: NotFoundError / OverconstrainedError, no camera
 * - {@link CameraBusyError} `busy`: NotReadableError / AbortError, in use elsewhere or failed to
 *   start, or no frame within the timeout
 * - {@link CameraError} `failed`: anything else
 *
 * ## Frames
 *
 * {@link FrameGrabber} draws the video's *current* frame into an OffscreenCanvas on demand, so
 * whatever it returns is the newest frame the browser has (newest frame wins: nothing queues).
 * `onFrame(cb)` says when a new camera frame has arrived (`requestVideoFrameCallback` where the
 * browser has it, else `requestAnimationFrame` polling `video.currentTime`); while an async
 * callback is still running, further frames are coalesced and the callback runs once more
 * afterwards for the newest of them.
 *
 * Pixels are the browser's sRGB conversion of the camera's YUV (what `drawImage` produces), top
 * row first, 4 bytes per pixel (R, G, B, A = 255).
 */

/** Base class of the errors `openCamera` rejects with. */
export class CameraError extends Error {
  /**
   * @param {string} message
   * @param {{code?: string, cause?: unknown}} [options]
   */
  constructor(message, { code = 'failed', cause } = {}) {
    super(message, cause === undefined ? undefined : { cause });
    this.name = 'CameraError';
    /** Stable machine-readable reason, see the file comment. */
    this.code = code;
  }
}

/** The page is not a secure context, so the browser hides the camera. */
export class InsecureContextError extends CameraError {
  /** @param {string} message @param {{cause?: unknown}} [options] */
  constructor(message, options = {}) {
    super(message, { ...options, code: 'insecure-context' });
    this.name = 'InsecureContextError';
  }
}

/** The browser has no getUserMedia at all. */
export class CameraUnsupportedError extends CameraError {
  /** @param {string} message @param {{cause?: unknown}} [options] */
  constructor(message, options = {}) {
    super(message, { ...options, code: 'unsupported' });
    this.name = 'CameraUnsupportedError';
  }
}

/** The user (or a permissions policy) refused the camera. */
export class CameraPermissionError extends CameraError {
  /** @param {string} message @param {{cause?: unknown}} [options] */
  constructor(message, options = {}) {
    super(message, { ...options, code: 'permission-denied' });
    this.name = 'CameraPermissionError';
  }
}

/** There is no camera (or none that can satisfy the request). */
export class CameraNotFoundError extends CameraError {
  /** @param {string} message @param {{cause?: unknown}} [options] */
  constructor(message, options = {}) {
    super(message, { ...options, code: 'not-found' });
    this.name = 'CameraNotFoundError';
  }
}

/** The camera exists but could not be started (another app holds it, hardware error). */
export class CameraBusyError extends CameraError {
  /** @param {string} message @param {{cause?: unknown}} [options] */
  constructor(message, options = {}) {
    super(message, { ...options, code: 'busy' });
    this.name = 'CameraBusyError';
  }
}

/**
 * Maps a getUserMedia rejection to one of this module's errors.
 * @param {unknown} e
 * @returns {CameraError}
 */
function cameraErrorFrom(e) {
  const name = e && typeof e === 'object' && 'name' in e ? String(e.name) : '';
  const detail = e && typeof e === 'object' && 'message' in e && e.message ? `: ${e.message}` : '';
  switch (name) {
    case 'NotAllowedError':
    case 'PermissionDeniedError': // pre-standard Chrome
    case 'SecurityError':
      return new CameraPermissionError(`camera access was refused (${name}${detail})`, { cause: e });
    case 'NotFoundError':
    case 'DevicesNotFoundError': // pre-standard Chrome
    case 'OverconstrainedError':
      return new CameraNotFoundError(`no usable camera (${name}${detail})`, { cause: e });
    case 'NotReadableError':
    case 'TrackStartError': // pre-standard Chrome
    case 'AbortError':
      return new CameraBusyError(`the camera could not be started (${name}${detail})`, { cause: e });
    default:
      return new CameraError(`opening the camera failed (${name || String(e)}${detail})`, { cause: e });
  }
}

/**
 * Resolves once the video element has decoded its first frame (videoWidth known).
 * @param {HTMLVideoElement} video
 * @param {number} timeoutMs
 * @returns {Promise<void>}
 */
function firstFrame(video, timeoutMs) {
  if (video.readyState >= 2 && video.videoWidth > 0) return Promise.resolve();
  return new Promise((resolve, reject) => {
    const done = (err) => {
      clearTimeout(timer);
      video.removeEventListener('loadeddata', check);
      video.removeEventListener('resize', check);
      video.removeEventListener('playing', check);
      if (err) reject(err);
      else resolve();
    };
    const check = () => {
      if (video.readyState >= 2 && video.videoWidth > 0) done();
    };
    const timer = setTimeout(
      () => done(new CameraBusyError(`the camera delivered no frame within ${timeoutMs} ms`)),
      timeoutMs,
    );
    video.addEventListener('loadeddata', check);
    video.addEventListener('resize', check);
    video.addEventListener('playing', check);
    check();
  });
}

/** Throws where the page is not a secure context, so the browser hides the camera. */
function requireSecureContext() {
  if (globalThis.isSecureContext === false) {
    const origin = globalThis.location ? globalThis.location.origin : 'this page';
    throw new InsecureContextError(
      `the camera needs a secure context (https:// or http://localhost); ${origin} is not one`,
    );
  }
}

/**
 * The browser's `navigator.mediaDevices`, or a throw where it has no getUserMedia.
 * @returns {MediaDevices}
 */
function requireMediaDevices() {
  const mediaDevices = globalThis.navigator ? globalThis.navigator.mediaDevices : undefined;
  if (!mediaDevices || typeof mediaDevices.getUserMedia !== 'function') {
    throw new CameraUnsupportedError('this browser has no navigator.mediaDevices.getUserMedia');
  }
  return mediaDevices;
}

/**
 * Asks for a video-only stream, preferably from the rear camera at the given size (`ideal`, so
 * any camera and any size still do).
 * @param {MediaDevices} mediaDevices
 * @param {number} width
 * @param {number} height
 * @returns {Promise<MediaStream>}
 * @throws {CameraError} the rejection mapped by cameraErrorFrom
 */
async function requestCameraStream(mediaDevices, width, height) {
  try {
    return await mediaDevices.getUserMedia({
      video: {
        facingMode: { ideal: 'environment' },
        width: { ideal: width },
        height: { ideal: height },
      },
      audio: false,
    });
  } catch (e) {
    throw cameraErrorFrom(e);
  }
}

/**
 * The stream's video track; where it has none, stops its other tracks and throws.
 * @param {MediaStream} stream
 * @returns {MediaStreamTrack}
 */
function requireVideoTrack(stream) {
  const track = stream.getVideoTracks()[0];
  if (!track) {
    for (const t of stream.getTracks()) t.stop();
    throw new CameraNotFoundError('getUserMedia returned a stream without a video track');
  }
  return track;
}

/**
 * A detached, muted, inline `<video>` element set to play the stream.
 * @param {MediaStream} stream
 * @returns {HTMLVideoElement}
 */
function createCameraVideo(stream) {
  const video = document.createElement('video');
  video.muted = true;
  video.defaultMuted = true;
  video.playsInline = true;
  video.setAttribute('playsinline', ''); // older iOS Safari reads the attribute only
  video.setAttribute('muted', '');
  video.autoplay = true;
  video.srcObject = stream;
  return video;
}

/**
 * Stops the stream's tracks and detaches it from the video.
 * @param {MediaStream} stream
 * @param {HTMLVideoElement} video
 */
function stopCamera(stream, video) {
  for (const t of stream.getTracks()) t.stop();
  video.pause();
  video.srcObject = null;
}

/**
 * Starts the video and waits for its first frame; on failure calls `stop` and throws.
 * @param {HTMLVideoElement} video
 * @param {number} timeoutMs
 * @param {() => void} stop
 * @returns {Promise<void>}
 * @throws {CameraError} firstFrame's timeout as is, a play() rejection mapped by cameraErrorFrom
 */
async function playUntilFirstFrame(video, timeoutMs, stop) {
  try {
    await video.play();
    await firstFrame(video, timeoutMs);
  } catch (e) {
    stop();
    throw e instanceof CameraError ? e : cameraErrorFrom(e);
  }
}

/**
 * @typedef {object} ExposureLock
 * @property {boolean} locked whether the exposure no longer follows the scene
 * @property {number|null} exposureTime the exposure time in seconds (the track's `exposureTime`
 *   setting, which is in units of 100 µs), or null where the browser does not report it
 * @property {string} reason how it was locked, or why it could not be
 */

/**
 * The track's current exposure time in seconds, or null where the browser does not report it.
 * @param {MediaStreamTrack} track
 * @returns {number|null}
 */
function exposureSeconds(track) {
  const s = track.getSettings();
  return typeof s.exposureTime === 'number' ? s.exposureTime * 1e-4 : null;
}

/**
 * Applies one exposure mode; the lock where the track then reports that mode, else null with
 * the reason pushed onto `failures`.
 * @param {MediaStreamTrack} track
 * @param {{exposureMode: string, exposureTime?: number}} constraint
 * @param {string[]} failures
 * @returns {Promise<ExposureLock|null>}
 */
async function tryExposureMode(track, constraint, failures) {
  const mode = constraint.exposureMode;
  try {
    await track.applyConstraints({ advanced: [constraint] });
    if (track.getSettings().exposureMode === mode) {
      return { locked: true, exposureTime: exposureSeconds(track), reason: `exposureMode ${mode}` };
    }
    failures.push(`${mode} was not applied`);
  } catch (e) {
    failures.push(`${mode} failed (${e && e.name ? e.name : e})`);
  }
  return null;
}

/**
 * What the camera says about its exposure modes, for an unlocked ExposureLock's `reason`.
 * @param {string[]|null} modes
 * @param {MediaTrackCapabilities|null} capabilities
 * @returns {string}
 */
function exposureModesNote(modes, capabilities) {
  if (modes) return `modes: ${modes.join(', ') || 'none'}`;
  return capabilities ? 'the camera reports no exposureMode capability' : 'capabilities unknown';
}

/**
 * Locks the track's exposure: manual at the time the auto exposure has reached, else
 * single-shot; where neither takes, leaves it (back) on continuous.
 * @param {MediaStreamTrack} track
 * @param {MediaTrackCapabilities|null} capabilities as read when the camera was opened
 * @returns {Promise<ExposureLock>}
 */
async function lockTrackExposure(track, capabilities) {
  if (track.readyState !== 'live') {
    return { locked: false, exposureTime: null, reason: 'the camera is closed' };
  }
  if (typeof track.applyConstraints !== 'function') {
    return { locked: false, exposureTime: null, reason: 'applyConstraints is not supported' };
  }
  const modes = capabilities && Array.isArray(capabilities.exposureMode)
    ? capabilities.exposureMode
    : null;
  const failures = [];

  // 1. manual: hold the exposure time the auto exposure has reached (where it is reported).
  if (!modes || modes.includes('manual')) {
    const current = track.getSettings().exposureTime;
    const manual = typeof current === 'number'
      ? { exposureMode: 'manual', exposureTime: current }
      : { exposureMode: 'manual' };
    const lock = await tryExposureMode(track, manual, failures);
    if (lock) return lock;
  } else {
    failures.push('no manual exposure mode');
  }

  // 2. single-shot: one auto exposure, then held.
  if (modes && modes.includes('single-shot')) {
    const lock = await tryExposureMode(track, { exposureMode: 'single-shot' }, failures);
    if (lock) return lock;
  }

  // 3. Not lockable: make sure the exposure keeps adapting rather than stuck half-way.
  if (modes && modes.includes('continuous')) {
    try {
      await track.applyConstraints({ advanced: [{ exposureMode: 'continuous' }] });
    } catch {
      // Nothing more to try; report the failures gathered above.
    }
  }
  return {
    locked: false,
    exposureTime: exposureSeconds(track),
    reason: `exposure stays automatic: ${failures.join('; ')} `
      + `(${exposureModesNote(modes, capabilities)})`,
  };
}

/**
 * @typedef {object} Camera
 * @property {HTMLVideoElement} video playing the camera stream (muted, playsInline, not in the
 *   document; add it to show the preview)
 * @property {number} width frame width from the track's settings (falls back to videoWidth)
 * @property {number} height frame height from the track's settings (falls back to videoHeight)
 * @property {MediaStreamTrack} track the video track
 * @property {MediaStream} stream
 * @property {MediaTrackSettings} settings the track's settings right after opening
 * @property {MediaTrackCapabilities|null} capabilities `track.getCapabilities()` where the browser
 *   has it (Firefox has not), else null
 * @property {() => Promise<ExposureLock>} lockExposure
 * @property {() => void} close stops the track and detaches the video
 */

/**
 * Opens the rear ("environment") camera, falling back to any camera, and starts playing it in a
 * detached `<video>` element.
 *
 * The size is a preference (`ideal`), not a requirement: read the returned `width` and `height`.
 * On a phone held in portrait the delivered frames may be taller than wide.
 *
 * @param {{width?: number, height?: number, timeoutMs?: number}} [options]
 *   `timeoutMs` bounds the wait for the first frame (default 10 s).
 * @returns {Promise<Camera>}
 * @throws {CameraError} a subclass naming the reason (see the file comment)
 */
export async function openCamera({ width = 640, height = 480, timeoutMs = 10000 } = {}) {
  requireSecureContext();
  const mediaDevices = requireMediaDevices();
  const stream = await requestCameraStream(mediaDevices, width, height);
  const track = requireVideoTrack(stream);
  const video = createCameraVideo(stream);
  const stop = () => stopCamera(stream, video);
  await playUntilFirstFrame(video, timeoutMs, stop);

  const settings = typeof track.getSettings === 'function' ? track.getSettings() : {};
  const capabilities =
    typeof track.getCapabilities === 'function' ? track.getCapabilities() : null;
  return {
    video,
    width: settings.width || video.videoWidth,
    height: settings.height || video.videoHeight,
    track,
    stream,
    settings,
    capabilities,
    lockExposure: () => lockTrackExposure(track, capabilities),
    close: stop,
  };
}

/**
 * @typedef {object} FrameInfo
 * @property {number} mediaTime the frame's presentation time in seconds (rVFC's `mediaTime`, or
 *   `video.currentTime` in the requestAnimationFrame fallback)
 * @property {number} now the callback's `performance.now()`-based time stamp (ms)
 * @property {number} width the frame's width as the video element has it
 * @property {number} height the frame's height
 * @property {number|undefined} presentedFrames rVFC's running frame count (undefined in the
 *   fallback)
 * @property {number|undefined} captureTime rVFC's capture time stamp (ms) where the browser has it
 * @property {number} dropped how many new frames were coalesced into this call because the
 *   previous callback was still running (presentedFrames gaps included where known)
 * @property {*} captured what `onFrame`'s `capture` took as the frame arrived (undefined without)
 */

/**
 * Grabs the current frame of a playing video as pixels or as JPEG.
 *
 * Each `rgba()` / `jpeg()` call draws the video's current frame first (pass `{redraw: false}` to
 * reuse the last drawn one, e.g. for the RGBA and the JPEG of the same frame).
 */
/**
 * The video's current frame as something a worker can take (transferable, drawable with
 * drawImage, closed with close()): a WebCodecs VideoFrame where the browser has them — for a
 * camera in CPU memory that wraps the frame without a copy or a colour conversion, which the
 * page's workers then do themselves — else an ImageBitmap (a copy through the GPU process).
 * @param {HTMLVideoElement} video
 * @returns {Promise<VideoFrame|ImageBitmap>}
 */
export async function snapshotFrame(video) {
  if (typeof VideoFrame === 'function') {
    try {
      return new VideoFrame(video);
    } catch {
      // e.g. no frame yet, or a browser that cannot wrap this video: the bitmap below
    }
  }
  return createImageBitmap(video);
}

export class FrameGrabber {
  /**
   * @param {HTMLVideoElement} video a playing video (e.g. `openCamera()`'s)
   * @param {{width?: number, height?: number}} [size] the output size; frames are scaled to it.
   *   Without it the output follows the video's own size (videoWidth × videoHeight), which
   *   changes when a phone is turned.
   */
  constructor(video, { width, height } = {}) {
    if (!video) throw new TypeError('FrameGrabber needs a video element');
    this.video = video;
    this._fixed = Boolean(width && height);
    const w = width || video.videoWidth;
    const h = height || video.videoHeight;
    if (!(w > 0 && h > 0)) {
      throw new RangeError('FrameGrabber: the video has no size yet (wait for its first frame)');
    }
    if (typeof OffscreenCanvas === 'function') {
      this.canvas = new OffscreenCanvas(w, h);
    } else {
      // Safari before 16.4: a detached canvas element does the same job.
      this.canvas = document.createElement('canvas');
      this.canvas.width = w;
      this.canvas.height = h;
    }
    const ctx = this.canvas.getContext('2d', { willReadFrequently: true, alpha: false });
    if (!ctx) throw new Error('FrameGrabber: no 2d canvas context');
    /** @type {OffscreenCanvasRenderingContext2D|CanvasRenderingContext2D} */
    this.ctx = ctx;
    this._drawn = false;
    this._stopFrames = null;
  }

  /** Output width in pixels. */
  get width() {
    return this.canvas.width;
  }

  /** Output height in pixels. */
  get height() {
    return this.canvas.height;
  }

  /**
   * Draws the video's current frame into the canvas (resizing the canvas first when the output
   * follows the video and the video's size changed).
   * @returns {{width: number, height: number, mediaTime: number}}
   */
  draw() {
    const v = this.video;
    if (!(v.readyState >= 2 && v.videoWidth > 0)) {
      throw new Error('FrameGrabber: the video has no current frame');
    }
    if (!this._fixed && (v.videoWidth !== this.canvas.width || v.videoHeight !== this.canvas.height)) {
      this.canvas.width = v.videoWidth;
      this.canvas.height = v.videoHeight;
    }
    this.ctx.drawImage(v, 0, 0, this.canvas.width, this.canvas.height);
    this._drawn = true;
    return { width: this.canvas.width, height: this.canvas.height, mediaTime: v.currentTime };
  }

  /**
   * The frame's pixels: width × height × 4 bytes, RGBA, top row first.
   * @param {{redraw?: boolean}} [options] `redraw: false` reuses the last drawn frame
   * @returns {Uint8ClampedArray}
   */
  rgba({ redraw = true } = {}) {
    if (redraw || !this._drawn) this.draw();
    return this.ctx.getImageData(0, 0, this.canvas.width, this.canvas.height).data;
  }

  /**
   * The frame as a JPEG file.
   * @param {number} [quality] 0 … 1
   * @param {{redraw?: boolean}} [options] `redraw: false` encodes the last drawn frame
   * @returns {Promise<Uint8Array>} starts with FF D8
   */
  async jpeg(quality = 0.85, { redraw = true } = {}) {
    if (redraw || !this._drawn) this.draw();
    /** @type {Blob} */
    let blob;
    if (typeof this.canvas.convertToBlob === 'function') {
      blob = await this.canvas.convertToBlob({ type: 'image/jpeg', quality });
    } else {
      blob = await new Promise((resolve, reject) => {
        this.canvas.toBlob(
          (b) => (b ? resolve(b) : reject(new Error('FrameGrabber: JPEG encoding failed'))),
          'image/jpeg',
          quality,
        );
      });
    }
    if (blob.type && blob.type !== 'image/jpeg') {
      throw new Error(`FrameGrabber: the browser encoded ${blob.type}, not image/jpeg`);
    }
    return new Uint8Array(await blob.arrayBuffer());
  }

  /**
   * Calls `cb` once for each new camera frame, newest frame wins: while a callback's promise is
   * pending, newer frames are coalesced and `cb` runs once more afterwards (with `dropped` > 0).
   * Only one subscriber; a second call replaces the first. `capture(info)` runs as each frame
   * arrives, before any wait, and its result comes as `info.captured`: what must belong to that
   * very frame (the video's current frame, the sensors' reading then), not to a newer one shown
   * by the time a coalesced frame's turn comes. `release(captured)` gets a dropped frame's.
   * @param {(info: FrameInfo) => (void|Promise<void>)} cb
   * @param {{capture?: (info: FrameInfo) => *, release?: (captured: *) => void}} [hooks]
   * @returns {() => void} stops the callbacks
   */
  onFrame(cb, { capture = () => undefined, release = () => {} } = {}) {
    if (this._stopFrames) this._stopFrames();
    const v = this.video;
    let stopped = false;
    let busy = false;
    /** @type {FrameInfo|null} */
    let pending = null;
    let coalesced = 0;
    let lastPresented;

    const run = (info) => {
      busy = true;
      let result;
      try {
        result = cb(info);
      } catch (e) {
        busy = false;
        reportCallbackError(e);
        return;
      }
      Promise.resolve(result)
        .catch(reportCallbackError)
        .finally(() => {
          busy = false;
          if (!stopped && pending) {
            const next = pending;
            pending = null;
            next.dropped += coalesced;
            coalesced = 0;
            run(next);
          }
        });
    };
    const deliver = (info) => {
      if (stopped) return;
      try {
        info.captured = capture(info);
      } catch (e) {
        reportCallbackError(e);
      }
      if (busy) {
        if (pending) {
          coalesced += 1 + pending.dropped;
          release(pending.captured);
        }
        pending = info;
        return;
      }
      run(info);
    };
    const dropPending = () => {
      if (pending) release(pending.captured);
      pending = null;
    };

    if (typeof v.requestVideoFrameCallback === 'function') {
      let handle = 0;
      const onVideoFrame = (now, meta) => {
        if (stopped) return;
        handle = v.requestVideoFrameCallback(onVideoFrame);
        const skipped = lastPresented !== undefined && meta.presentedFrames > lastPresented + 1
          ? meta.presentedFrames - lastPresented - 1
          : 0;
        lastPresented = meta.presentedFrames;
        deliver({
          mediaTime: meta.mediaTime,
          now,
          width: meta.width,
          height: meta.height,
          presentedFrames: meta.presentedFrames,
          captureTime: meta.captureTime,
          dropped: skipped,
        });
      };
      handle = v.requestVideoFrameCallback(onVideoFrame);
      this._stopFrames = () => {
        stopped = true;
        v.cancelVideoFrameCallback(handle);
        dropPending();
        this._stopFrames = null;
      };
    } else {
      let handle = 0;
      let lastTime = -1;
      const onAnimationFrame = (now) => {
        if (stopped) return;
        handle = requestAnimationFrame(onAnimationFrame);
        if (v.readyState < 2 || v.currentTime === lastTime) return;
        lastTime = v.currentTime;
        deliver({
          mediaTime: v.currentTime,
          now,
          width: v.videoWidth,
          height: v.videoHeight,
          presentedFrames: undefined,
          captureTime: undefined,
          dropped: 0,
        });
      };
      handle = requestAnimationFrame(onAnimationFrame);
      this._stopFrames = () => {
        stopped = true;
        cancelAnimationFrame(handle);
        dropPending();
        this._stopFrames = null;
      };
    }
    return this._stopFrames;
  }

  /** Stops `onFrame` callbacks and frees the canvas memory. */
  close() {
    if (this._stopFrames) this._stopFrames();
    this.canvas.width = 1;
    this.canvas.height = 1;
    this._drawn = false;
  }
}

/**
 * Reports an exception from an `onFrame` callback without stopping the callbacks.
 * @param {unknown} e
 */
function reportCallbackError(e) {
  if (typeof globalThis.reportError === 'function') globalThis.reportError(e);
  else setTimeout(() => { throw e; });
}
