// The page's controls, wired to the renderer (the WebClient): the field of view, the model, the
// selects (material, shading, refraction, colour), the soft shadows' lights and "the sun from my
// location". The URL's choices (params.js) come first, each control's own value else.
import { showError, state } from './status.js';

const $ = (id) => document.getElementById(id);
const kFovKey = 'arlight.fov';  // localStorage: the field of view last used on this phone

// The camera's vertical field of view (degrees), the client's intrinsics with it: the URL's
// (&fov=), else the last one used here, else 63. The #fov input sets it, and so does the focal
// length the marker's views refine (setFocal). Either calls onDegrees(degrees) (the coverage
// view's cone) and onIntrinsics() (arlightd is told), in the order the page always has.
export class FieldOfView {
  constructor(client, height, fromUrl) {
    this.client = client;
    this.height = height;  // the camera's, in pixels
    this.onDegrees = () => {};
    this.onIntrinsics = () => {};
    this.degrees = Number(fromUrl || localStorage.getItem(kFovKey) || 63);
    $('fov').value = String(this.degrees);
    client.setFov(this.degrees);
    state.focalPx = client.camera().fx;
    $('fov').addEventListener('change', (e) => {
      try {
        client.setFov(Number(e.target.value));
        state.focalPx = client.camera().fx;
        this.degrees = Number(e.target.value);
        this.onDegrees(this.degrees);
        localStorage.setItem(kFovKey, e.target.value);
        this.onIntrinsics();
      } catch (err) {
        showError(String(err.message || err));
      }
    });
  }

  /** A focal length in pixels (the marker's, marker_tracking.js), shown as its field of view. */
  setFocal(f) {
    this.client.setFocal(f);
    state.focalPx = f;
    this.onIntrinsics();
    this.degrees = (2 * Math.atan(this.height / 2 / f) * 180) / Math.PI;
    $('fov').value = this.degrees.toFixed(1);
    localStorage.setItem(kFovKey, this.degrees.toFixed(1));
    this.onDegrees(this.degrees);
  }
}

/** params.js's shadowLights (null: the client's defaults), or its error shown. */
export function setShadowLights(client, shadowLights) {
  if (!shadowLights) return;
  if (shadowLights.error) showError(shadowLights.error);
  else client.setShadowLights(shadowLights.lights, shadowLights.fps);
}

/** The URL's choices for the selects (named like their ids), else the selects' own. */
export function wireSelects(client, choices) {
  for (const [id, set] of [['material', (v) => client.setMaterial(v)],
    ['shading', (v) => client.setShading(v)], ['refraction', (v) => client.setRefraction(v)],
    ['colour', (v) => client.setColour(v)]]) {
    const value = choices[id] || $(id).value;
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
}

// Models other than the sphere are files beside the page (models/NAME.glb); `onLoaded` after one
// is in use.
async function setModel(client, name, onLoaded) {
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
    onLoaded();
  } catch (e) {
    showError(String(e.message || e));
  }
}

/**
 * The #model select, and the URL's model (a name, or null: the sphere the client starts with);
 * `onLoaded` after each model is in use.
 */
export function wireModel(client, fromUrl, onLoaded = () => {}) {
  $('model').addEventListener('change', (e) => setModel(client, e.target.value, onLoaded));
  if (fromUrl) setModel(client, fromUrl, onLoaded);
}

/** "The sun from my location" (ticked by the URL's &location=1, or kept by the browser). */
export function wireLocation(place, fromUrl) {
  const box = $('use-location');
  if (fromUrl) box.checked = true;
  if (box.checked) place.ask();
  box.addEventListener('change', (e) => {
    if (e.target.checked) place.ask();
    else place.forget();
  });
}
