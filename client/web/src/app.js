// The arlight page: what only a browser has — the camera, the motion sensors, the WebSocket to
// arlightd — around the project's C++ compiled to WebAssembly (arlight_web.js: the protocol
// codec, the map-set assembly and the renderer). Frames go to arlightd as JPEG with the camera's
// orientation; lighting comes back (live SH, then a map set) and the renderer composites the
// object over the camera view in the canvas. A worker finds the marker (marker_worker.js,
// opencv.js); the C++ pose filter places the object on it, and its views refine the focal length.
//
// The URL's fragment (never sent to the server in an HTTP request) carries the session:
//   #device=D&token=T[&autostart=1][&fov=DEG][&size=WxH][&material=plastic|matte|metal|glass]
//   [&marker=ID,SIZE_M]  (DICT_4X4_50, as the native client's --marker; default 0,0.2)
//   [&model=sphere|bunny|suzanne][&session=ID]  (continue that session: its map so far)
//   [&shading=maps|hemisphere|hemisphere-occlusion]  (as arlight-client's --shading)
//   [&refraction=live|maps]  (what glass shows through it, as arlight-client's --glass)
//   [&colour=none|match|brightness|contrast]  (as arlight-client's --tone camera,CORRECTION)
//   [&location=1]  (tick "the sun from my location": the browser still asks its user)
//   [&upload=auto|video|yuv|canvas|imagedata]  (how the camera frame reaches WebGL:
//   frame_upload.js)
//   [&shadowLights=N][&fps=F]  (soft shadows: at most N hard shadows, 1-32, default 16, as many
//   as hold F frames a second, default 30, 0: always N; arlight-client's --shadow-lights,
//   --target-fps)
// window.arlight.status() reports what the page is doing (tests read it).
import createArlight from './arlight_web.js';
import { openCamera, FrameGrabber, snapshotFrame } from './camera.js';
import {
  cameraQuatFromDeviceOrientation,
  cameraQuatFromSensorQuaternion,
  quatRotateVector,
} from './orientation.js';
import { focalEstimate } from './intrinsics.js';
import { FrameUpload } from './frame_upload.js';

const params = new URLSearchParams(location.hash.slice(1));
const $ = (id) => document.getElementById(id);

// Sending: at most this much may wait in the WebSocket before a newer frame replaces the next.
const kMaxBuffered = 256 * 1024;
const kJpegQuality = 0.85;
const kReconnectMs = 1000;

const state = {
  client: null,  // the WebAssembly WebClient, once the page runs
  upload: null,  // its FrameUpload
  connected: false,
  sessionId: params.get('session') || '',  // sent as the Hello's resume_session
  framesSent: 0,
  updates: 0,
  framesProcessed: 0,
  mapSets: 0,
  trackedFrames: 0,
  trackStatus: 'starting',  // 'tracked', or why not ('no marker in view', a refusal, ...)
  trackMs: 0,               // the worker's time for the last frame
  tracks: [],               // the recent tracking results (window.arlight.tracks())
  sent: [],                 // the recent frames sent (window.arlight.sent())
  intrinsics: 'default',    // or 'refined' (from the marker's views)
  refinedMediaTime: null,   // the frame shown when the focal length was last refined
  focalPx: 0,
  focalError: null,             // the marker views' relative standard error of the focal length
  tracker: 'loading',           // opencv.js in the worker: 'loading', 'ready' or 'failed'
  trackerReadyMediaTime: null,  // the frame shown when it became ready
  frameMediaTime: null,         // the media time of the frame shown last (null before the first)
  tracking: 'preview',  // the object floats ahead of the view; 'marker' once it stands on it
  fps: 0,
  lastError: '',
  lighting: 'none',
  coverage: 0,
  guideElevation: 85,  // the capture guide's next row (CoverageView.nextElevation)
  estimated: 0,
  renderMs: 0,
  grabMs: 0,      // the camera frame into the renderer's texture
  jpegMs: 0,      // encoding the newest frame for arlightd
  latencies: [],  // ms from sending a frame to the update that reflects it
  refused: false,
  started: false,
  orientation: 'none',
  geolocation: 'off',  // off, asked, granted, refused or unavailable (the sun from the location)
  cameraOpenedAt: 0,   // Date.now() when the camera opened (its first frame; tests pace sensors)
  sh: [],              // bands 0-2 of the live SH, RGB triples
  readyMs: 0,          // navigation start to the renderer ready (WASM loaded, shaders compiled)
};

// Set once the page runs: see start().
let probeComposite = () => null;

window.arlight = {
  // For tests and for people wondering whether the object is where they think: the object's
  // centre in the canvas, and at that pixel, at the canvas corner farthest from it and on the
  // floor just in front of it (its contact shadow; null before it stands on the marker), the
  // composite's RGB beside the camera frame's RGB it was drawn over.
  probe() {
    return probeComposite();
  },
  // The recent marker poses: {media_time (the frame's, as the camera stamped it), raw, smoothed
  // (the camera's pose in the marker frame: position in metres, orientation [w, x, y, z]),
  // velocity (the pose filter's, m/s in the marker frame), reprojection_px}.
  tracks() {
    return state.tracks.slice();
  },
  // The recent frames sent to arlightd: {media_time (the frame's), orientation (camera -> world,
  // [w, x, y, z], as sent with it)}.
  sent() {
    return state.sent.slice();
  },
  status() {
    const sorted = [...state.latencies].sort((a, b) => a - b);
    const pick = (p) => (sorted.length ? sorted[Math.min(sorted.length - 1, Math.floor(p * sorted.length))] : 0);
    const object = state.client ? state.client.status() : null;
    return {
      connected: state.connected,
      session_id: state.sessionId,
      frames_sent: state.framesSent,
      updates: state.updates,
      frames_processed: state.framesProcessed,
      map_sets: state.mapSets,
      tracked_frames: state.trackedFrames,
      track_status: state.trackStatus,
      track_ms: state.trackMs,
      intrinsics: state.intrinsics,
      intrinsics_refined_media_time: state.refinedMediaTime,
      focal_px: state.focalPx,
      model: object ? object.model : 'sphere',
      model_vertices: object ? object.model_vertices : 0,
      shadow_lights: object ? object.shadow_lights : 0,
      shadow_ms: object ? object.shadow_ms : 0,
      shadow_light_budget: object ? object.shadow_light_budget : 0,
      max_shadow_lights: object ? object.max_shadow_lights : 0,
      target_fps: object ? object.target_fps : 0,
      shading: object ? object.shading : 'maps',
      material: object ? object.material : 'plastic',
      refraction: object ? object.refraction : 'live',
      colour: object ? object.colour : 'none',
      sun: object ? object.sun : 'unknown',
      sun_direction: object ? object.sun_direction : [0, 0, 0],
      geolocation: state.geolocation,
      focal_error: state.focalError,
      tracker: state.tracker,
      tracker_ready_media_time: state.trackerReadyMediaTime,
      tracking: state.tracking,
      fps: state.fps,
      last_error: state.lastError,
      lighting: state.lighting,
      coverage: state.coverage,
      estimated: state.estimated,
      guide_elevation_deg: state.guideElevation,
      render_ms: state.renderMs,
      grab_ms: state.grabMs,
      upload: state.upload ? state.upload.method : 'none',
      ready_ms: state.readyMs,
      jpeg_ms: state.jpegMs,
      latency_p50_ms: pick(0.5),
      latency_p99_ms: pick(0.99),
      orientation: state.orientation,
      started: state.started,
      camera_opened_at: state.cameraOpenedAt,
      frame_media_time: state.frameMediaTime,
      sh: state.sh,
    };
  },
};

function showError(message) {
  state.lastError = message;
  $('error').textContent = message;
}

// The camera's orientation (camera -> world, [w, x, y, z]) from whatever the browser offers.
function startOrientation() {
  let latest = [1, 0, 0, 0];
  const screenAngle = () => (screen.orientation ? screen.orientation.angle : window.orientation || 0);
  if ('AbsoluteOrientationSensor' in window) {
    try {
      const sensor = new AbsoluteOrientationSensor({ frequency: 60, referenceFrame: 'device' });
      sensor.addEventListener('reading', () => {
        latest = cameraQuatFromSensorQuaternion(sensor.quaternion, screenAngle());
        state.orientation = 'absolute-orientation-sensor';
      });
      sensor.addEventListener('error', (e) => showError(`orientation sensor: ${e.error.name}`));
      sensor.start();
    } catch (e) {
      showError(`orientation sensor: ${e.name || e}`);
    }
  }
  window.addEventListener('deviceorientation', (e) => {
    if (state.orientation === 'absolute-orientation-sensor' || e.alpha === null) return;
    latest = cameraQuatFromDeviceOrientation(e.alpha, e.beta, e.gamma, screenAngle());
    state.orientation = 'deviceorientation';
  });
  return () => latest;
}

// Cells of a 36 x 18 lat-long grid the camera has looked at (its view cone), drawn as a map of
// where the capture has been and where to point next.
class CoverageView {
  constructor(canvas, fovYDeg, aspect) {
    this.ctx = canvas.getContext('2d');
    this.cols = 36;
    this.rows = 18;
    this.seen = new Uint8Array(this.cols * this.rows);
    this.setFov(fovYDeg, aspect);
    this.dirs = [];
    for (let r = 0; r < this.rows; ++r) {
      for (let c = 0; c < this.cols; ++c) {
        const phi = 2 * Math.PI * ((c + 0.5) / this.cols - 0.5);
        const el = Math.PI * (0.5 - (r + 0.5) / this.rows);
        // common/CONVENTIONS.md lat-long: u = 0.5 is -Z, v = 0 is +Y.
        this.dirs.push([Math.sin(phi) * Math.cos(el), Math.sin(el), -Math.cos(phi) * Math.cos(el)]);
      }
    }
  }
  setFov(fovYDeg, aspect) {
    const half = Math.atan(Math.tan((fovYDeg * Math.PI) / 360) * Math.min(1, aspect));
    this.cosHalf = Math.cos(half);
  }
  add(q) {
    const f = quatRotateVector(q, [0, 0, -1]);
    this.dirs.forEach((d, i) => {
      if (d[0] * f[0] + d[1] * f[1] + d[2] * f[2] >= this.cosHalf) this.seen[i] = 1;
    });
  }
  // The capture guide (issue 16 §1): the elevation (degrees, the row's centre) of the highest
  // row not yet three-quarters seen, null once every row is. A room's light comes mostly from
  // above (lamps, the sky), and arlightd's estimate of the unseen part is best once the upper
  // hemisphere is measured: swept from the ceiling down, the irradiance at 60 % coverage is
  // about twice as close to the truth as swept from the horizon out (bench/RESULTS.md).
  nextElevation() {
    for (let r = 0; r < this.rows; ++r) {
      let seen = 0;
      for (let c = 0; c < this.cols; ++c) seen += this.seen[r * this.cols + c];
      if (seen < 0.75 * this.cols) return 90 - ((r + 0.5) * 180) / this.rows;
    }
    return null;
  }
  // `next`: the guide's row (nextElevation(), or null: none drawn).
  draw(forward, next) {
    const { ctx } = this;
    const w = ctx.canvas.width / this.cols;
    const h = ctx.canvas.height / this.rows;
    ctx.fillStyle = '#222';
    ctx.fillRect(0, 0, ctx.canvas.width, ctx.canvas.height);
    ctx.fillStyle = '#3fb950';
    this.seen.forEach((s, i) => {
      if (s) ctx.fillRect((i % this.cols) * w, Math.floor(i / this.cols) * h, w, h);
    });
    if (next !== null) {  // the row to sweep next, outlined
      ctx.strokeStyle = '#e3b341';
      ctx.lineWidth = 2;
      ctx.strokeRect(1, (0.5 - next / 180) * ctx.canvas.height - h / 2, ctx.canvas.width - 2, h);
      ctx.lineWidth = 1;
    }
    if (forward) {  // where the camera looks now
      const phi = Math.atan2(forward[0], -forward[2]);
      const el = Math.asin(Math.max(-1, Math.min(1, forward[1])));
      ctx.strokeStyle = '#fff';
      ctx.strokeRect((phi / (2 * Math.PI) + 0.5) * ctx.canvas.width - 4,
        (0.5 - el / Math.PI) * ctx.canvas.height - 4, 8, 8);
    }
  }
}

// What the guide's row asks of the user, in words.
function guideText(elevation) {
  if (elevation === null) return 'all round: done';
  if (elevation > 75) return 'look straight up';
  if (elevation < -75) return 'look straight down';
  return `sweep round at ${Math.abs(elevation).toFixed(0)}° ${elevation >= 0 ? 'up' : 'down'}`;
}

// Marker tracking in its worker (marker_worker.js): one frame at a time, the newest offered wins;
// every frame while the marker is tracked, a few a second while it is not (a search costs as much
// as a frame's tracking, and the rest of the page needs the cores). Started first thing on Start:
// opencv.js takes seconds to load, while the camera opens.
const kSearchIntervalMs = 250;

class MarkerTracking {
  constructor(marker, onError) {
    this.ready = false;
    this.busy = false;
    this.next = 0;
    this.frames = new Map();  // what the page knew of each frame in the worker
    this.found = false;       // in the last result
    this.lastOffer = -Infinity;
    this.onReady = () => {};
    this.onResult = () => {};  // (found, frame, ms): marker.js's detect() result
    this.worker = new Worker('marker_worker.js');
    this.worker.onmessage = ({ data }) => {
      if (data.type === 'ready') {
        this.ready = true;
        this.onReady();
        return;
      }
      const frame = this.frames.get(data.id);
      this.frames.delete(data.id);
      this.busy = false;
      if (data.type === 'result') this.found = Boolean(data.found && !data.found.refused);
      if (data.type === 'result' && frame) this.onResult(data.found, frame, data.ms);
      else if (data.type === 'error') onError(data.message, this.ready);
    };
    this.worker.onerror = (e) => onError(e.message || 'the tracking worker failed', this.ready);
    this.worker.postMessage({ type: 'marker', ...marker });
  }
  // The frame the page shows now (`take` gives a transferable copy of it), with what it knows of
  // it ({t, q, mediaTime}); skipped while the worker is busy or still loading opencv.js.
  async offer(take, k, frame) {
    if (!this.ready || this.busy) return;
    const now = performance.now();
    if (!this.found && now - this.lastOffer < kSearchIntervalMs) return;
    this.lastOffer = now;
    this.busy = true;
    const id = ++this.next;
    this.frames.set(id, frame);
    try {
      const image = await take();
      this.worker.postMessage({ type: 'frame', id, image, k }, [image]);
    } catch {
      this.frames.delete(id);
      this.busy = false;
    }
  }
}

// "ID,SIZE_M" (the native client's --marker) -> {id, size, dictionary}.
function parseMarker(text) {
  const [id, size] = text.split(',').map(Number);
  if (!Number.isInteger(id) || id < 0 || id >= 50 || !(size > 0.005 && size < 10))
    throw new RangeError(`marker "${text}": ID,SIZE_M with ID in 0-49 and SIZE_M in metres`);
  return { id, size, dictionary: 'DICT_4X4_50' };
}

// JPEG encoding in a worker (jpeg_worker.js says why).
class JpegEncoder {
  constructor() {
    this.worker = new Worker('jpeg_worker.js');
    this.pending = new Map();
    this.next = 0;
    this.worker.onmessage = ({ data }) => {
      const p = this.pending.get(data.id);
      this.pending.delete(data.id);
      if (!p) return;
      if (data.error) p.reject(new Error(data.error));
      else p.resolve(new Uint8Array(data.jpeg));
    };
  }
  encode(image, quality) {
    const id = ++this.next;
    return new Promise((resolve, reject) => {
      this.pending.set(id, { resolve, reject });
      this.worker.postMessage({ id, image, quality }, [image]);
    });
  }
}

async function start() {
  if (state.started) return;
  state.started = true;
  $('start').disabled = true;
  const device = params.get('device');
  const token = params.get('token');
  if (!device || !token) {
    showError('this page needs #device=…&token=… in its address: scan the QR code arlightd prints');
    return;
  }
  // iOS asks for motion sensors on a tap.
  if (typeof DeviceOrientationEvent !== 'undefined' &&
      typeof DeviceOrientationEvent.requestPermission === 'function') {
    try {
      await DeviceOrientationEvent.requestPermission();
    } catch (e) {
      showError(`motion sensors: ${e.name || e}`);
    }
  }
  let marker;
  try {
    marker = parseMarker(params.get('marker') || '0,0.2');
  } catch (e) {
    showError(String(e.message || e));
    return;
  }
  const tracking = new MarkerTracking(marker, (message, ready) => {
    if (!ready) state.tracker = 'failed';
    showError(`tracking: ${message}`);
  });
  // The module next: the camera's frames start as soon as it opens.
  const module = await createArlight();
  const [width, height] = (params.get('size') || '640x480').split('x').map(Number);
  let camera;
  try {
    camera = await openCamera({ width, height });
  } catch (e) {
    showError(`camera: ${e.message || e}`);
    return;
  }
  state.cameraOpenedAt = Date.now();
  const w = camera.width;
  const h = camera.height;
  const canvas = $('view');
  canvas.width = w;
  canvas.height = h;
  const client = new module.WebClient('#view', w, h);
  state.client = client;
  state.readyMs = performance.now();  // since the page's navigation started: its first load
  const fov = Number(params.get('fov') || localStorage.getItem('arlight.fov') || 63);
  $('fov').value = String(fov);
  client.setFov(fov);
  state.focalPx = client.camera().fx;
  client.setMarkerSize(marker.size);
  if (params.has('shadowLights') || params.has('fps')) {
    const lights = Number(params.get('shadowLights') || 16), fps = Number(params.get('fps') || 30);
    if (!Number.isInteger(lights) || lights < 1 || lights > 32) {
      showError(`shadowLights '${params.get('shadowLights')}': a whole number from 1 to 32`);
    } else if (!Number.isFinite(fps) || fps < 0) {
      showError(`fps '${params.get('fps')}': frames a second, 0 for no frame-rate control`);
    } else {
      client.setShadowLights(lights, fps);
    }
  }
  // The URL's choices for the selects (named like their ids), else the selects' own.
  for (const [id, set] of [['material', (v) => client.setMaterial(v)],
    ['shading', (v) => client.setShading(v)], ['refraction', (v) => client.setRefraction(v)],
    ['colour', (v) => client.setColour(v)]]) {
    const value = params.get(id) || $(id).value;
    const options = [...$(id).options].map((o) => o.value);
    if (options.includes(value)) {
      $(id).value = value;
      set(value);
    } else {
      showError(`${id} '${value}': ${options.join(', ')}`);
      set($(id).value);
    }
    $(id).addEventListener('change', (e) => set(e.target.value));
  }
  const coverage = new CoverageView($('coverage'), fov, w / h);
  const orientation = startOrientation();
  const grabber = new FrameGrabber(camera.video, { width: w, height: h });
  camera.lockExposure().catch(() => {});

  // Models other than the sphere are files beside the page (models/NAME.glb).
  const setModel = async (name) => {
    try {
      let bytes = new Uint8Array(0);
      if (name !== 'sphere') {
        const response = await fetch(`models/${encodeURIComponent(name)}.glb`);
        if (!response.ok) throw new Error(`model ${name}: ${response.status} ${response.statusText}`);
        bytes = new Uint8Array(await response.arrayBuffer());
      }
      const why = client.setModel(name, bytes);
      if (why) throw new Error(why);
      $('model').value = name;
    } catch (e) {
      showError(String(e.message || e));
    }
  };
  $('model').addEventListener('change', (e) => setModel(e.target.value));
  if (params.get('model')) setModel(params.get('model'));
  const sendIntrinsics = () => {
    if (ws && ws.readyState === WebSocket.OPEN) ws.send(client.intrinsics());
  };
  $('fov').addEventListener('change', (e) => {
    try {
      client.setFov(Number(e.target.value));
      state.focalPx = client.camera().fx;
      coverage.setFov(Number(e.target.value), w / h);
      localStorage.setItem('arlight.fov', e.target.value);
      sendIntrinsics();
    } catch (err) {
      showError(String(err.message || err));
    }
  });

  // ---- where the phone is, for the sun: only when its user ticks the box (and the browser's
  // own prompt agrees); sent after every Welcome of a server that takes it ----
  let ws = null;
  let place = null;  // {latitude, longitude, altitude, utc (s), at (performance.now(), ms)}
  const sendLocation = () => {
    if (!place || !ws || ws.readyState !== WebSocket.OPEN) return;
    const utc = place.utc + (performance.now() - place.at) / 1000;
    const bytes = client.location(place.latitude, place.longitude, place.altitude, utc,
      state.orientation === 'absolute-orientation-sensor');
    if (bytes) ws.send(bytes);
  };
  const askLocation = () => {
    if (!navigator.geolocation) {
      state.geolocation = 'unavailable';
      showError('location: this browser has no geolocation');
      return;
    }
    state.geolocation = 'asked';
    navigator.geolocation.getCurrentPosition((p) => {
      place = { latitude: p.coords.latitude, longitude: p.coords.longitude,
        altitude: p.coords.altitude ?? 0, utc: Date.now() / 1000, at: performance.now() };
      state.geolocation = 'granted';
      sendLocation();
    }, (e) => {
      state.geolocation = 'refused';
      showError(`location: ${e.message || e.code}`);
    }, { maximumAge: 600000, timeout: 30000 });
  };
  if (params.get('location') === '1') $('use-location').checked = true;
  if ($('use-location').checked) askLocation();
  $('use-location').addEventListener('change', (e) => {
    if (e.target.checked) askLocation();
    else place = null;  // sent no more (arlightd keeps what it had for this session)
  });

  // ---- the connection: Hello, intrinsics, a map request; resumed after a drop ----
  let sequence = 0;
  const sentAt = new Map();
  let encoding = false;
  const connect = () => {
    ws = new WebSocket(`wss://${location.host}/ws`);
    ws.binaryType = 'arraybuffer';
    ws.onopen = () => {
      ws.send(client.hello(device, token, state.sessionId));
      ws.send(client.intrinsics());
      ws.send(client.requestMaps());
    };
    ws.onmessage = (event) => {
      const name = client.receive(new Uint8Array(event.data));
      const s = client.status();
      if (name === 'Welcome') {
        state.connected = true;
        state.sessionId = s.session_id;
        sendLocation();
      } else if (name === 'LightingUpdate') {
        state.updates = s.updates;
        state.sh = s.sh;
        state.framesProcessed = s.frames_processed;
        state.coverage = s.coverage;
        state.estimated = s.estimated;
        const t = sentAt.get(s.last_sequence);
        if (t !== undefined) {
          state.latencies.push(performance.now() - t);
          if (state.latencies.length > 2000) state.latencies.shift();
          for (const k of sentAt.keys()) if (k <= s.last_sequence) sentAt.delete(k);
        }
      } else if (name === 'MapSetComplete') {
        state.mapSets = s.map_sets;
      } else if (name === 'Error') {
        showError(`refused: ${s.last_error}`);
        if (/^(Unauthorized|Unsupported|SessionNotFound)/.test(s.last_error)) state.refused = true;
      } else if (name.startsWith('refused')) {
        showError(name);
        ws.close();
      }
      state.lighting = s.lighting;
    };
    ws.onclose = () => {
      state.connected = false;
      if (!state.refused) setTimeout(connect, kReconnectMs);
    };
  };
  connect();

  // ---- the marker: its pose into the C++ filter, its views into the focal length ----
  const views = [];    // the newest 64 views' corners
  let viewsSeen = 0;
  let refineAt = 8;    // views seen; doubling, then every 64
  const refineFocal = (corners) => {
    views.push(corners);
    if (views.length > 64) views.shift();
    if (++viewsSeen < refineAt) return;
    refineAt = Math.min(2 * refineAt, refineAt + 64);
    const k = client.camera();
    const estimate = focalEstimate(views, k.cx, k.cy);
    if (!estimate) return;
    // Only a well-determined focal length (1 % standard error), and only a change it is sure of:
    // views of a marker seen nearly square-on say little, and a worse focal length moves the
    // object by as many per cent of its distance.
    const { focal: f, relativeError } = estimate;
    state.focalError = relativeError;
    if (!(relativeError < 0.01) || !(f > 0.5 * k.fx && f < 2 * k.fx) ||
        Math.abs(f / k.fx - 1) < Math.max(0.005, 2 * relativeError)) return;
    client.setFocal(f);
    state.focalPx = f;
    sendIntrinsics();
    const fovY = (2 * Math.atan(h / 2 / f) * 180) / Math.PI;
    $('fov').value = fovY.toFixed(1);
    localStorage.setItem('arlight.fov', fovY.toFixed(1));
    coverage.setFov(fovY, w / h);
    state.intrinsics = 'refined';
    state.refinedMediaTime = state.frameMediaTime;
  };
  tracking.onReady = () => {
    state.tracker = 'ready';
    // Ready before the first frame was shown (a warm cache): ready for every frame.
    state.trackerReadyMediaTime = state.frameMediaTime ?? 0;
  };
  if (tracking.ready) tracking.onReady();
  tracking.onResult = (found, frame, ms) => {
    state.trackMs = ms;
    if (!found || found.refused) {
      state.trackStatus = found ? `marker ${marker.id} refused: ${found.refused}` : `marker ${marker.id} not in view`;
      // A refused pose's corners still tell the focal length (a wrong one is often why).
      if (found) refineFocal(found.corners);
      return;
    }
    const pose = client.markerSeen(frame.t, ...found.rvec, ...found.tvec, ...frame.q);
    ++state.trackedFrames;
    state.trackStatus = 'tracked';
    state.tracking = 'marker';
    state.tracks.push({ media_time: frame.mediaTime, raw: pose.raw, smoothed: pose.smoothed, velocity: pose.velocity,
      reprojection_px: found.reprojectionPx });
    if (state.tracks.length > 1000) state.tracks.shift();
    refineFocal(found.corners);
  };

  // ---- every camera frame (newest wins): composite it, and send it unless one is on its way ----
  let frames = 0;
  let since = performance.now();
  const encoder = new JpegEncoder();
  const sendFrame = async (q, take, mediaTime) => {
    encoding = true;
    try {
      const t0 = performance.now();
      // The frame drawn for the composite, encoded off the main thread.
      const jpeg = await encoder.encode(await take(), kJpegQuality);
      state.jpegMs = performance.now() - t0;
      const seq = ++sequence;
      ws.send(client.frame(seq, performance.now() / 1000, q[0], q[1], q[2], q[3], jpeg));
      sentAt.set(seq, performance.now());
      state.framesSent = seq;
      state.sent.push({ media_time: mediaTime, orientation: q });
      if (state.sent.length > 1000) state.sent.shift();
      coverage.add(q);
    } catch (e) {
      showError(`frame: ${e.message || e}`);
    } finally {
      encoding = false;
    }
  };
  const updatePanel = (q) => {
    // A session continued from another page (#session=ID) may be seen all round already.
    state.guideElevation = state.coverage >= 0.99 ? null : coverage.nextElevation();
    coverage.draw(quatRotateVector(q, [0, 0, -1]), state.guideElevation);
    $('s-guide').textContent = guideText(state.guideElevation);
    $('s-connection').textContent = state.connected ? `session ${state.sessionId.slice(0, 8)}` : 'connecting…';
    $('s-frames').textContent = `${state.framesSent} sent, ${state.framesProcessed} in the map`;
    $('s-lighting').textContent = `${state.lighting}, ${state.mapSets} map sets, ${(state.coverage * 100).toFixed(0)} % seen` +
      (state.estimated > 0 ? `, ${(state.estimated * 100).toFixed(0)} % estimated` : '');
    $('s-marker').textContent = `${state.trackStatus}, ${state.trackedFrames} frames`;
    const p = window.arlight.status();
    $('s-speed').textContent =
        `${state.fps.toFixed(1)} fps, ${state.renderMs.toFixed(1)} ms a frame, latency ${
            p.latency_p50_ms.toFixed(0)} ms` +
        (p.shadow_lights > 0 ? `, ${p.shadow_lights} shadow lights` : '');
  };
  // The camera frame into the renderer's texture (frame_upload.js: the <video> or its planes,
  // whichever is faster here), then the composite; one at a time, the newest frame wins.
  let upload;
  try {
    upload = new FrameUpload(module, client, camera.video, grabber,
      { width: w, height: h, mode: params.get('upload') || 'auto' });
  } catch (e) {
    showError(String(e.message || e));
    return;
  }
  state.upload = upload;
  let compositing = null;
  const composite = async (t, q, image = null, measure = true) => {
    while (compositing) await compositing;
    compositing = (async () => {
      state.grabMs = await upload.upload(image, { measure });
      state.renderMs = client.render(t, q[0], q[1], q[2], q[3]);
      client.frameTook(state.grabMs + state.renderMs);  // the soft shadow's frame-rate control
    })();
    try {
      await compositing;
    } finally {
      compositing = null;
    }
  };
  const readBack = document.createElement('canvas');
  readBack.width = w;
  readBack.height = h;
  const readCtx = readBack.getContext('2d', { willReadFrequently: true });
  // One snapshot of the video's current frame drawn for reference and composited the page's way
  // with the orientation that frame came with, and the canvas read back. (The video may be a
  // frame ahead of the page's last frame callback: then its orientation is waited for.)
  let shown = { t: 0, q: [1, 0, 0, 0], mediaTime: undefined };
  const recent = new Map();  // media time -> orientation, of the last frames shown
  probeComposite = async () => {
    let image;
    let mediaTime = shown.mediaTime;
    for (let attempt = 0; ; ++attempt) {
      image = await snapshotFrame(camera.video);
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
      await composite(t, q, image, false);
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
  grabber.onFrame(async (info) => {
    state.frameMediaTime = info.mediaTime;
    const q = orientation();
    const t = performance.now() / 1000;  // the frame's time, as the tracker's results carry it
    shown = { t, q, mediaTime: info.mediaTime };
    recent.set(info.mediaTime, shown);
    if (recent.size > 8) recent.delete(recent.keys().next().value);
    // One VideoFrame of what shows now, for the composite, the tracker and arlightd alike (each
    // paired with the orientation read with it); a fresh bitmap each where there are none.
    let video = null;
    try {
      if (typeof VideoFrame === 'function') video = new VideoFrame(camera.video);
    } catch {
      video = null;  // this browser cannot wrap the video: bitmaps
    }
    const take = () => (video ? Promise.resolve(video.clone()) : createImageBitmap(camera.video));
    try {
      tracking.offer(take, client.camera(), { t, q, mediaTime: info.mediaTime });
      if (compositing) return;  // still on the previous frame: this one is skipped
      try {
        await composite(t, q, video);
        ++frames;
      } catch (e) {
        if (!/no current frame/.test(String(e.message))) showError(`render: ${e.message || e}`);
        return;
      }
      if (state.connected && !encoding && ws.readyState === WebSocket.OPEN &&
          ws.bufferedAmount <= kMaxBuffered) sendFrame(q, take, info.mediaTime);
    } finally {
      // The clones handed out stay valid; this one is done once the composite has it.
      if (video) video.close();
    }
    const now = performance.now();
    if (now - since >= 1000) {
      state.fps = (frames * 1000) / (now - since);
      frames = 0;
      since = now;
      updatePanel(q);
    }
  });
}

$('start').addEventListener('click', start);
if (params.get('autostart') === '1') start();
