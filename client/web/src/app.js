// The arlight page: what only a browser has — the camera, the motion sensors, the WebSocket to
// arlightd — around the project's C++ compiled to WebAssembly (arlight_web.js: the protocol
// codec, the map-set assembly and the renderer). Frames go to arlightd as JPEG with the camera's
// orientation; lighting comes back (live SH, then a map set) and the renderer composites the
// object over the camera view in the canvas. A worker finds the marker (marker_worker.js,
// opencv.js); the C++ pose filter places the object on it, and its views refine the focal length.
//
// This file starts the page and runs its frame loop; each part is a module of its own:
//   params.js          the URL's fragment (the session and the page's choices: listed there)
//   status.js          what the page is doing (window.arlight.status()), showError
//   sensors.js         the camera's orientation from the motion sensors
//   marker_tracking.js the marker: its worker, its poses, the focal length from its views
//   controls.js        the field of view, the model, the selects, the location checkbox
//   geolocation.js     where the phone is, for the sun
//   connection.js      the WebSocket to arlightd (jpeg_encoder.js encodes the frames it sends)
//   coverage_view.js   where the camera has looked; status_panel.js the panel in words
//   compositor.js      the camera frame into WebGL (frame_upload.js) and the object over it
//   test_hooks.js      window.arlight, for tests (status(), tracks(), sent(), probe())
import createArlight from './arlight_web.js';
import { openCamera, FrameGrabber } from './camera.js';
import { FrameUpload } from './frame_upload.js';
import { parseParams } from './params.js';
import { showError, state } from './status.js';
import { askMotionPermission, startOrientation } from './sensors.js';
import { MarkerTracking } from './marker_tracking.js';
import { FieldOfView, setShadowLights, wireLocation, wireModel, wireSelects } from './controls.js';
import { Place } from './geolocation.js';
import { Connection } from './connection.js';
import { CoverageView } from './coverage_view.js';
import { updatePanel } from './status_panel.js';
import { Compositor } from './compositor.js';
import { enableProbe, installHooks, recordDrawn } from './test_hooks.js';

const $ = (id) => document.getElementById(id);

// Parsed at load, as the page was opened: Start later uses the same, and status() reports the
// session to resume before it.
const params = parseParams(location.hash);
state.sessionId = params.session;
installHooks();

// The sensors' permission, the marker's tracker, the module, the camera and the renderer; null
// where one is missing (showError has said why).
async function open(params) {
  if (!params.device || !params.token) {
    showError('this page needs #device=…&token=… in its address: scan the QR code arlightd prints');
    return null;
  }
  await askMotionPermission();
  if (params.markerError || params.placementError || params.joinError) {
    showError(params.markerError || params.placementError || params.joinError);
    return null;
  }
  const tracking = new MarkerTracking(params.marker);
  // The module next: the camera's frames start as soon as it opens.
  const module = await createArlight();
  const [width, height] = params.size;
  let camera;
  try {
    camera = await openCamera({ width, height });
  } catch (e) {
    showError(`camera: ${e.message || e}`);
    return null;
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
  return { module, camera, client, tracking, canvas, width: w, height: h };
}

// The controls, the sensors, the connection and the tracker's results, all wired to the client.
// In the page's own order: of two errors shown here, the later one stays on the page.
function wireUp(params, { camera, client, tracking, width, height }) {
  const fov = new FieldOfView(client, height, params.fov);
  client.setMarkerSize(params.marker.size);
  setShadowLights(client, params.shadowLights);
  wireSelects(client, params.choices);
  const coverage = new CoverageView($('coverage'), fov.degrees, width / height);
  const orientation = startOrientation();
  const grabber = new FrameGrabber(camera.video, { width, height });
  camera.lockExposure().catch(() => {});
  const connection = new Connection(client, params);
  // A model with metallic-roughness materials, drawn "from the model", needs the GGX chain.
  wireModel(client, params.model, () => connection.sendIfOpen(() => client.requestMapsIfChanged()));
  fov.onDegrees = (degrees) => coverage.setFov(degrees, width / height);
  fov.onIntrinsics = () => connection.sendIntrinsics();
  // Where the phone is, for the sun: sent when the browser gives it and after every Welcome.
  const place = new Place(client);
  const sendPlace = () => connection.sendIfOpen(() => place.message());
  place.onPlace = sendPlace;
  connection.onWelcome = sendPlace;
  wireLocation(place, params.location);
  connection.onFrameSent = (q) => coverage.add(q);
  // A metallic-roughness material shades with the room's GGX chain, the others with the Phong
  // maps: a change of kind asks arlightd for the other (the select's own listener ran first).
  $('material').addEventListener('change',
    () => connection.sendIfOpen(() => client.requestMapsIfChanged()));
  connection.open();
  tracking.follow(client, (f) => fov.setFocal(f));
  return { coverage, orientation, grabber, connection };
}

// Every camera frame (the newest wins): its orientation read, offered to the tracker,
// composited, and sent unless one is on its way; the panel once a second.
function loop(params, { module, camera, client, tracking, canvas, width, height },
  { coverage, orientation, grabber, connection }) {
  let frames = 0;
  let since = performance.now();
  // The camera frame into the renderer's texture (frame_upload.js: the <video> or its planes,
  // whichever is faster here), then the composite; one at a time, the newest frame wins.
  let upload;
  try {
    upload = new FrameUpload(module, client, camera.video, grabber,
      { width, height, mode: params.upload });
  } catch (e) {
    showError(String(e.message || e));
    return;
  }
  state.upload = upload;
  const compositor = new Compositor(upload, client);
  const frameShown = enableProbe({ video: camera.video, grabber, canvas, client, compositor, width, height });
  // As each frame arrives: one VideoFrame of it (a bitmap is made when needed where there are
  // none), when it was taken (s, performance.now()'s clock: the tracker's results and the
  // placement carry it) and the orientation then, kept together while an earlier frame is
  // composited.
  const capture = (info) => {
    let video = null;
    try {
      if (typeof VideoFrame === 'function') video = new VideoFrame(camera.video);
    } catch {
      video = null;  // this browser cannot wrap the video: bitmaps
    }
    // The frame's own media time: new VideoFrame(video) in a frame callback is often a newer
    // frame than the callback's (1-8 frames at 30 fps here while the page is busy).
    const mediaTime = video && Number.isFinite(video.timestamp) ? video.timestamp / 1e6 : info.mediaTime;
    // Taken tens of milliseconds before it reaches the page (60-200 ms here): the callback's
    // capture time, moved by the media time between its frame and this one. Browsers that do
    // not say: now.
    const takenMs = Number.isFinite(info.captureTime)
      ? info.captureTime + 1000 * (mediaTime - info.mediaTime) : performance.now();
    return { q: orientation(takenMs), t: takenMs / 1000, video, mediaTime };
  };
  const release = (captured) => captured && captured.video && captured.video.close();
  // A frame into the canvas with its own orientation and time (and the pose the tracker found
  // in it, when it waited for one); the panel once a second.
  const show = async ({ q, t, video, mediaTime }) => {
    try {
      await compositor.composite(t, q, video);
    } catch (e) {
      if (!/no current frame/.test(String(e.message))) showError(`render: ${e.message || e}`);
      return false;
    }
    recordDrawn(client, mediaTime, t);
    ++frames;
    const now = performance.now();
    if (now - since >= 1000) {
      state.fps = (frames * 1000) / (now - since);
      frames = 0;
      since = now;
      updatePanel(coverage, q, params);
    }
    return true;
  };
  grabber.onFrame(async (info) => {
    const { captured } = info;
    if (!captured) return;  // capture() failed (reported): nothing of this frame to show
    const { q, t, video, mediaTime } = captured;
    state.frameMediaTime = mediaTime;
    frameShown(t, q, mediaTime);
    // The frame for the tracker, the composite and arlightd alike (each paired with the
    // orientation read as it arrived). The clones handed out stay valid: take() runs before the
    // offers return.
    const take = () => (video ? Promise.resolve(video.clone()) : createImageBitmap(camera.video));
    // Issue 36 §4, registration first: while the marker is tracked, a frame is shown only with
    // the pose the tracker finds in it (the worker's time later), and the frames that reach the
    // page while the worker is busy are not shown. Predicting the pose of frames the tracker has
    // not seen missed by up to ~300 px at 30 fps on a 2-core machine (bench/RESULTS.md, issue 36
    // part 4). A frame in which the marker is not found is not shown; once it has been lost for
    // a moment, or before it is found (opencv.js loading, searching), every frame shows at once.
    const registering = params.placement === 'registered' && tracking.registering;
    const registration = tracking.offer(take, client.camera(), { t, q, mediaTime });
    if (registering) {
      connection.offerFrame(q, take, mediaTime);
      if (registration) registration.then((found) => found && show(captured)).finally(() => release(captured));
      else release(captured);
      return;
    }
    try {
      if (compositor.busy) return;  // still on the previous frame: this one is skipped
      if (await show(captured)) connection.offerFrame(q, take, mediaTime);
    } finally {
      release(captured);  // done once the composite has it
    }
  }, { capture, release });
}

// Start (the button, or &autostart=1), with the parameters parsed at load.
async function start() {
  if (state.started) return;
  state.started = true;
  $('start').disabled = true;
  const page = await open(params);
  if (!page) return;
  const parts = wireUp(params, page);
  loop(params, page, parts);
}

$('start').addEventListener('click', start);
if (params.autostart) start();
