// /three.html: a glTF model in three.js (its own GLTFLoader and MeshStandardMaterial), lit by the
// room a session is capturing — ArlightEstimatedLight (client/web/three/) watching the session.
// On a desktop the model turns under the room's light; on a second phone (`camera=1`) it stands
// over that phone's camera. Its parameters are in the URL's fragment (never sent to a server):
//   #session=ID&device=D&token=T[&model=spheres|bunny|suzanne|tiles|URL][&camera=1]
//   [&filter=arlight|pmrem][&face=256][&exposure=STOPS]
// `model=URL` loads a .glb or .gltf of this origin (the page's policy allows no other).
// For tests and people: window.arlightThree.status() and .lightEstimate() (WebXR's shape).
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { ArlightEstimatedLight } from './three/ArlightEstimatedLight.js';
import { renderSpheresLinear, sphereGrid } from './sphere_grid.js';

const kBundled = { bunny: 'models/bunny.glb', suzanne: 'models/suzanne.glb', tiles: 'models/tiles.glb' };
const kFpsWindowMs = 1000;

const params = new URLSearchParams(location.hash.slice(1));
const canvas = document.getElementById('view');
const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, alpha: params.get('camera') === '1' });
renderer.toneMapping = THREE.ACESFilmicToneMapping;
const scene = new THREE.Scene();
const camera = new THREE.PerspectiveCamera(40, canvas.width / canvas.height, 0.05, 50);
camera.position.set(0, 0.15, 2.4);
const stage = new THREE.Group();
scene.add(stage);

let lastError = '';
let modelName = '';
const showError = (message) => {
  lastError = message;
  document.getElementById('hint').textContent = message;
};

async function loadModel(name) {
  if (name === 'spheres') return sphereGrid();
  const url = kBundled[name] || name;
  if (!/\.(glb|gltf)$/i.test(new URL(url, location.href).pathname))
    throw new Error(`model '${name}': one of spheres, ${Object.keys(kBundled).join(', ')} or a .glb/.gltf URL`);
  const gltf = await new GLTFLoader().loadAsync(url);
  const model = gltf.scene;
  // Fit it in a 1.2 m box at the origin.
  const box = new THREE.Box3().setFromObject(model);
  const size = box.getSize(new THREE.Vector3()).length();
  model.scale.setScalar(size > 0 ? 1.2 / size : 1);
  box.setFromObject(model);
  model.position.sub(box.getCenter(new THREE.Vector3()));
  return model;
}

const face = Number(params.get('face') || 256);
if (!(Number.isInteger(Math.log2(face)) && face >= 16 && face <= 1024))
  showError(`face '${params.get('face')}': a power of two from 16 to 1024`);
const light = new ArlightEstimatedLight(renderer, {
  session: params.get('session') || '', device: params.get('device') || '',
  token: params.get('token') || '', filter: params.get('filter') === 'pmrem' ? 'pmrem' : 'arlight',
  environmentFace: Number.isInteger(Math.log2(face)) && face >= 16 && face <= 1024 ? face : 256,
});
scene.add(light);
// The environment lights the model alone once it is here (diffuse from its last level, as three
// does): the probe and the primary light are XREstimatedLight's, for apps that want them.
light.addEventListener('estimationstart', () => {
  if (light.environment) scene.environment = light.environment;
});
const exposureStops = Number(params.get('exposure') || 0);
// Each estimate's arrival (for tests: how soon the capturing device's frame reached this scene).
const kUpdatesKept = 500;
const updateLog = [];
light.addEventListener('update', ({ frameSequence }) => {
  const sh = light.lightEstimate().sphericalHarmonicsCoefficients;
  updateLog.push({ sequence: frameSequence, at_ms: Date.now(), dc: [sh[0], sh[1], sh[2]] });
  if (updateLog.length > kUpdatesKept) updateLog.shift();
});

// Drag to turn the model.
let dragging = null;
canvas.addEventListener('pointerdown', (e) => { dragging = e.clientX; canvas.setPointerCapture(e.pointerId); });
canvas.addEventListener('pointerup', () => { dragging = null; });
canvas.addEventListener('pointermove', (e) => {
  if (dragging === null) return;
  stage.rotation.y += (e.clientX - dragging) * 0.01;
  dragging = e.clientX;
});

const frameTimes = [];
function render(now) {
  frameTimes.push(now);
  while (frameTimes.length && now - frameTimes[0] > kFpsWindowMs) frameTimes.shift();
  if (light.environment && scene.environment !== light.environment) {
    scene.environment = light.environment;
    if (params.get('camera') !== '1') {
      scene.background = light.environment;
      scene.backgroundBlurriness = 0.15;
    }
    light.lightProbe.visible = false;
    light.directionalLight.visible = false;
  }
  // Exposure: the room's mean radiance (the SH's DC term) to mid grey, then the page's stops.
  const estimate = light.lightEstimate();
  if (estimate) {
    const sh = estimate.sphericalHarmonicsCoefficients;
    const mean = 0.282095 * (0.2126 * sh[0] + 0.7152 * sh[1] + 0.0722 * sh[2]);
    if (mean > 0) renderer.toneMappingExposure = (0.18 / mean) * 2 ** exposureStops;
  }
  renderer.render(scene, camera);
  updateStatusPanel();
  requestAnimationFrame(render);
}

function status() {
  const s = light.status();
  return {
    ...s,
    model: modelName,
    fps: frameTimes.length > 1 ? ((frameTimes.length - 1) * 1000) / (frameTimes.at(-1) - frameTimes[0]) : 0,
    last_error: lastError || s.last_error,
  };
}

function updateStatusPanel() {
  const s = status();
  document.getElementById('s-connection').textContent = s.watching
    ? `watching ${s.session_id.slice(0, 8)}…` : s.last_error || 'connecting';
  document.getElementById('s-lighting').textContent =
    `${s.updates} updates, ${s.map_sets} map sets${s.environment_face ? `, environment ${s.environment_face}²` : ''}`;
  document.getElementById('s-speed').textContent = `${s.fps.toFixed(0)} fps`;
}

async function startCamera() {
  const video = document.getElementById('camera');
  try {
    video.srcObject = await navigator.mediaDevices.getUserMedia({ video: { facingMode: 'environment' } });
    video.hidden = false;
    document.getElementById('stage').classList.add('over-camera');
    await video.play();
  } catch (e) {
    showError(`camera: ${e.message || e}`);
  }
}

// For tests: what WebGL samples from the environment at each [x, y, z, lod] (RGBA floats).
function sampleEnvironment(dirs) {
  const n = dirs.length;
  const target = new THREE.WebGLRenderTarget(n, 1, { type: THREE.FloatType });
  const data = new Float32Array(n * 4);
  dirs.forEach((d, i) => data.set(d, 4 * i));
  const dirTexture = new THREE.DataTexture(data, n, 1, THREE.RGBAFormat, THREE.FloatType);
  dirTexture.needsUpdate = true;
  const material = new THREE.RawShaderMaterial({
    glslVersion: THREE.GLSL3,
    uniforms: { environment: { value: light.environment }, dirs: { value: dirTexture } },
    vertexShader: 'in vec3 position; void main() { gl_Position = vec4(position.xy, 0.0, 1.0); }',
    fragmentShader: `precision highp float; uniform samplerCube environment; uniform sampler2D dirs;
      out vec4 colour;
      void main() { vec4 d = texelFetch(dirs, ivec2(gl_FragCoord.xy), 0);
        colour = textureLod(environment, d.xyz, d.w); }`,
  });
  const quad = new THREE.Scene();
  quad.add(new THREE.Mesh(new THREE.PlaneGeometry(2, 2), material));
  renderer.setRenderTarget(target);
  renderer.render(quad, new THREE.Camera());
  renderer.setRenderTarget(null);
  const out = new Float32Array(n * 4);
  renderer.readRenderTargetPixels(target, 0, 0, n, 1, out);
  target.dispose();
  material.dispose();
  dirTexture.dispose();
  return Array.from(out);
}

window.arlightThree = {
  status, lightEstimate: () => light.lightEstimate(), light, sampleEnvironment,
  updates: () => updateLog.slice(),
  // arlight-bench-pbr's sphere grid under this page's environment (linear RGBA rows, bottom-up).
  renderSpheres: (camera, spheres, baseColour) =>
    renderSpheresLinear(renderer, light.environment, camera, spheres, baseColour).map((p) => Array.from(p)),
};

if (!params.get('session')) showError('no session: open this page from the capturing page\'s "watch this room" link');
if (params.get('camera') === '1') startCamera();
modelName = params.get('model') || 'spheres';
loadModel(modelName)
  .then((model) => stage.add(model))
  .catch((e) => showError(`model: ${e.message || e}`));
requestAnimationFrame(render);
