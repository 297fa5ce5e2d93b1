// The page's parameters, from its URL's fragment (never sent to the server in an HTTP request):
//   #device=D&token=T[&autostart=1][&fov=DEG][&size=WxH][&material=plastic|matte|metal|glass|gold|porcelain|model]
//   [&marker=ID,SIZE_M]  (DICT_4X4_50, as the native client's --marker; default 0,0.2)
//   [&model=sphere|bunny|suzanne|tiles][&session=ID]  (continue that session: its map so far)
//   [&join=ID]  (capture into that live session beside its own phone: the "capture with another
//   phone" link, whose token is a join token)
//   [&shading=maps|hemisphere|hemisphere-occlusion]  (as arlight-client's --shading)
//   [&refraction=live|maps]  (what glass shows through it, as arlight-client's --glass)
//   [&colour=none|match|brightness|contrast]  (as arlight-client's --tone camera,CORRECTION)
//   [&location=1]  (tick "the sun from my location": the browser still asks its user)
//   [&upload=auto|video|yuv|canvas|imagedata]  (how the camera frame reaches WebGL:
//   frame_upload.js)
//   [&placement=registered|predicted]  (on the marker: each frame shown with the pose the
//   tracker finds in it, a tracker's time later; or at once, with the newest pose moved on by
//   the sensor's rotation and the pose filter's velocity: marker_tracking.js)
//   [&shadowLights=N][&fps=F]  (soft shadows: at most N hard shadows, 1-32, default 16, as many
//   as hold F frames a second, default 30, 0: always N; arlight-client's --shadow-lights,
//   --target-fps)
// Parsing only: no DOM, nothing shown. A parameter that is wrong carries its error message, for
// the page to show at the step that uses it (so the last error shown stays the one it was). The
// selects' values are checked against their options where they are wired (controls.js), the
// upload method by frame_upload.js.

/** "ID,SIZE_M" (the native client's --marker) -> {id, size, dictionary}; throws a RangeError. */
export function parseMarker(text) {
  const [id, size] = text.split(',').map(Number);
  if (!Number.isInteger(id) || id < 0 || id >= 50 || !(size > 0.005 && size < 10))
    throw new RangeError(`marker "${text}": ID,SIZE_M with ID in 0-49 and SIZE_M in metres`);
  return { id, size, dictionary: 'DICT_4X4_50' };
}

// &shadowLights= and &fps=: null where neither is given, else {lights, fps, error} (error null
// when both are good).
function parseShadowLights(p) {
  if (!p.has('shadowLights') && !p.has('fps')) return null;
  const lights = Number(p.get('shadowLights') || 16);
  const fps = Number(p.get('fps') || 30);
  let error = null;
  if (!Number.isInteger(lights) || lights < 1 || lights > 32)
    error = `shadowLights '${p.get('shadowLights')}': a whole number from 1 to 32`;
  else if (!Number.isFinite(fps) || fps < 0)
    error = `fps '${p.get('fps')}': frames a second, 0 for no frame-rate control`;
  return { lights, fps, error };
}

/**
 * The parameters in `hash` (location.hash: '#...' or ''). Absent ones are null where the page
 * falls back to something of its own (the field of view kept from the last visit, the selects'
 * own values), else their defaults.
 */
export function parseParams(hash) {
  const p = new URLSearchParams(hash.slice(1));
  let marker = null;
  let markerError = null;
  try {
    marker = parseMarker(p.get('marker') || '0,0.2');
  } catch (e) {
    markerError = String(e.message || e);
  }
  const placement = p.get('placement') || 'registered';
  return {
    device: p.get('device'),
    token: p.get('token'),
    session: p.get('session') || '',  // sent as the Hello's resume_session
    join: p.get('join') || '',        // sent as the Hello's join_session
    joinError: !p.get('join') || /^[0-9a-f]{32}$/.test(p.get('join')) ? null
      : `join '${p.get('join')}': a session id (32 hex characters)`,
    autostart: p.get('autostart') === '1',
    size: (p.get('size') || '640x480').split('x').map(Number),  // [width, height] asked of the camera
    fov: p.get('fov'),  // degrees, as written
    marker,             // {id, size, dictionary}, or null and markerError
    markerError,
    placement,
    placementError: ['registered', 'predicted'].includes(placement) ? null
      : `placement '${placement}': registered or predicted`,
    shadowLights: parseShadowLights(p),
    model: p.get('model'),
    // The selects' choices, named like their ids.
    choices: {
      material: p.get('material'),
      shading: p.get('shading'),
      refraction: p.get('refraction'),
      colour: p.get('colour'),
    },
    location: p.get('location') === '1',
    upload: p.get('upload') || 'auto',
  };
}
