// What the page is doing: its state, each field written by the module named above it, and
// report(), the summary of it that window.arlight.status() returns (test_hooks.js; tests and
// independent checks read its fields by name) and the status panel shows (status_panel.js).
// showError puts a message on the page; the last one stays (status().last_error).

/**
 * The page capturing into this session from another phone (issue 49): a new device name, the
 * join token and the session, in the fragment; '' before a token came.
 */
export function joinUrl(sessionId, joinToken) {
  if (!sessionId || !joinToken) return '';
  const name = `phone-${joinToken.slice(0, 6)}`;
  const fragment = new URLSearchParams({ device: name, token: joinToken, join: sessionId });
  return `index.html#${fragment}`;
}

export const state = {
  // app.js: the page's start and what it opened
  started: false,
  client: null,     // the WebAssembly WebClient, once the page runs
  upload: null,     // its FrameUpload
  cameraOpenedAt: 0,  // Date.now() when the camera opened (its first frame; tests pace sensors)
  readyMs: 0,       // navigation start to the renderer ready (WASM loaded, shaders compiled)
  // app.js's frame loop and compositor.js
  frameMediaTime: null,  // the media time of the frame shown last (null before the first)
  fps: 0,
  renderMs: 0,
  grabMs: 0,        // the camera frame into the renderer's texture
  drawn: [],        // the recent composites (window.arlight.drawn())
  // connection.js
  connected: false,
  sessionId: '',    // sent as the Hello's resume_session (app.js sets the URL's &session=)
  framesSent: 0,
  jpegMs: 0,        // encoding the newest frame for arlightd
  latencies: [],    // ms from sending a frame to the update that reflects it
  sent: [],         // the recent frames sent (window.arlight.sent())
  // marker_tracking.js
  trackedFrames: 0,
  trackStatus: 'starting',  // 'tracked', or why not ('no marker in view', a refusal, ...)
  trackMs: 0,               // the worker's time for the last frame
  tracks: [],               // the recent tracking results (window.arlight.tracks())
  tracker: 'loading',       // opencv.js in the worker: 'loading', 'ready' or 'failed'
  trackerReadyMediaTime: null,  // the first frame offered to it once ready
  tracking: 'preview',  // the object floats ahead of the view; 'marker' once it stands on it
  intrinsics: 'default',    // or 'refined' (from the marker's views)
  refinedMediaTime: null,   // the frame shown when the focal length was last refined
  focalError: null,         // the marker views' relative standard error of the focal length
  // controls.js (FieldOfView)
  focalPx: 0,
  // status_panel.js
  guideElevation: 85,  // the elevation the guide asks for: arlightd's next view's, or the next row
  guideText: '',       // what the guide says (status_panel.js guideText)
  guideView: null,     // arlightd's next view the guide's words are for; null: the fixed rows
  // sensors.js
  orientation: 'none',
  // geolocation.js
  geolocation: 'off',  // off, asked, granted, refused or unavailable (the sun from the location)
  // showError
  lastError: '',
};

export function showError(message) {
  state.lastError = message;
  document.getElementById('error').textContent = message;
}

// What the client core built from arlightd's messages (updates, map sets, coverage, the live SH:
// web_status.cpp), read from the WebAssembly client when asked, not copied on every message;
// before the page runs, nothing yet.
const kNoClient = {
  updates: 0, frames_processed: 0, map_sets: 0, lighting: 'none', coverage: 0, estimated: 0,
  light_error: 0, light_error_zones: 0, light_error_map: [], next_view: null, next_view_gain: 0,
  sh: [], model: 'sphere', model_vertices: 0, model_materials: 0, model_warnings: [],
  shadow_lights: 0, shadow_ms: 0, joining: false, registration: 0, join_token: '',
  shadow_light_budget: 0, max_shadow_lights: 0, target_fps: 0, shading: 'maps',
  material: 'plastic', refraction: 'live', colour: 'none', sun: 'unknown', sun_direction: [0, 0, 0],
  ggx_face: 0, maps_requested: 'phong', frames_held_back: 0, frames_held_in_flight: 0,
  advised_width: 0, advised_height: 0, advised_fps: 0, advised_frame_bytes: 0, jpeg_quality: 0,
  last_sequence: 0, session_last_sequence: 0, session_resumed: false, saved_sequence: 0,
  frames_kept: 0, frames_resent: 0,
};
export function clientStatus() {
  return state.client ? state.client.status() : kNoClient;
}

/** The page's status: every field keeps its name and meaning (tests read them). */
export function report() {
  const sorted = [...state.latencies].sort((a, b) => a - b);
  const pick = (p) => (sorted.length ? sorted[Math.min(sorted.length - 1, Math.floor(p * sorted.length))] : 0);
  const object = clientStatus();
  return {
    connected: state.connected,
    session_id: state.sessionId,
    frames_sent: state.framesSent,
    // The daemon's frame advice (PROTOCOL.md): the size and rate it asks for, the frames it held
    // back; of them, those held while two frames were unanswered by a LightingUpdate (issue 36).
    frames_held_back: object.frames_held_back,
    frames_held_in_flight: object.frames_held_in_flight,
    advised_size: [object.advised_width, object.advised_height],
    advised_fps: object.advised_fps,
    // The bytes a frame may take to cross the uplink in 1/30 s, as arlightd measured it (0: no
    // advice), and the JPEG quality the page encodes its frames at to stay within them.
    advised_frame_bytes: object.advised_frame_bytes,
    jpeg_quality: object.jpeg_quality,
    updates: object.updates,
    // Fail-over (issue 36 §5): the newest frame an update answered, the newest the (resumed)
    // session held when it welcomed the page, whether it was resumed, the newest every frame up
    // to which a checkpoint holds, the frames kept for a fail-over and those sent again.
    last_sequence: object.last_sequence,
    session_last_sequence: object.session_last_sequence,
    session_resumed: object.session_resumed,
    saved_sequence: object.saved_sequence,
    // Two phones, one room (issue 49): whether this page contributes to another phone's session,
    // its frames' registration there (0 its own session, 1 waiting, 2 registered), and this
    // page's join link for another phone ('' before its token came; none while contributing).
    joining: object.joining,
    registration: object.registration,
    join_url: object.joining ? '' : joinUrl(state.sessionId, object.join_token),
    frames_kept: object.frames_kept,
    frames_resent: object.frames_resent,
    frames_processed: object.frames_processed,
    map_sets: object.map_sets,
    ggx_face: object.ggx_face,
    maps_requested: object.maps_requested,
    tracked_frames: state.trackedFrames,
    track_status: state.trackStatus,
    track_ms: state.trackMs,
    intrinsics: state.intrinsics,
    intrinsics_refined_media_time: state.refinedMediaTime,
    focal_px: state.focalPx,
    model: object.model,
    model_vertices: object.model_vertices,
    model_materials: object.model_materials,
    model_warnings: object.model_warnings,
    shadow_lights: object.shadow_lights,
    shadow_ms: object.shadow_ms,
    shadow_light_budget: object.shadow_light_budget,
    max_shadow_lights: object.max_shadow_lights,
    target_fps: object.target_fps,
    shading: object.shading,
    material: object.material,
    refraction: object.refraction,
    colour: object.colour,
    sun: object.sun,
    sun_direction: object.sun_direction,
    geolocation: state.geolocation,
    focal_error: state.focalError,
    tracker: state.tracker,
    tracker_ready_media_time: state.trackerReadyMediaTime,
    tracking: state.tracking,
    fps: state.fps,
    last_error: state.lastError,
    // Where a Moved answer sent this page last (HOST:PORT of the session's arlightd; issue 49 §2).
    moved_to: object.moved_to,
    lighting: object.lighting,
    coverage: object.coverage,
    estimated: object.estimated,
    light_error: object.light_error,
    next_view: object.next_view,
    next_view_gain: object.next_view_gain,
    guide_elevation_deg: state.guideElevation,
    guide: state.guideText,
    guide_view: state.guideView,
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
    sh: object.sh,
  };
}
