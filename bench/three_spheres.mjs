// three.js's metallic-roughness spheres against the full BRDF (issue 35 §1): the grid of
// arlight-bench-pbr (metallic 0 / 0.5 / 1 x roughness 0.05 ... 1, base colour (0.9, 0.64, 0.3),
// one sphere filling a 96 x 96 view) drawn by three.js's own MeshStandardMaterial in headless
// Chromium, lit by the room's GGX chain (arlight-maps ggx, face 256 -> 16) two ways:
//   arlight — the chain as ArlightEstimatedLight gives it to three (chainToPmrem: each level as
//             it is in three's PMREM texture, whose level <-> roughness mapping is the chain's);
//   pmrem   — the chain's mirror level filtered by three's own PMREMGenerator
//             (threePmremOfMirror),
// each pixel read back as linear radiance and scored against sim/reference's Embree reference of
// the same pixel (arlight-bench-pbr --reference): the mean relative error (thesis eq. 6.1), the
// mean absolute error over the mean radiance, PSNR with the reference's brightest pixel as the
// peak — and beside them arlight's own renderer's figures from the same run.
//   node bench/three_spheres.mjs BUILD_BIN OUT_DIR PROBE
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import http from 'node:http';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

import { launchChromium } from '../tests/web/harness.mjs';

if (process.argv.length < 5) {
  console.error('usage: node bench/three_spheres.mjs BUILD_BIN OUT_DIR PROBE');
  process.exit(2);
}
const [bin, out, probe] = process.argv.slice(2, 5).map((p) => path.resolve(p));
const ROOT = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..');
const THREE = path.join(ROOT, 'client', 'web', 'node_modules', 'three');
const MODULE = path.join(ROOT, 'client', 'web', 'three', 'src');
fs.mkdirSync(out, { recursive: true });

const PAGE = `<!doctype html><meta charset="utf-8">
<script type="importmap">{"imports": {"three": "/three/build/three.module.js",
  "three/addons/": "/three/examples/jsm/"}}</script>
<script type="module">
import * as THREE from 'three';
import { KTX2Loader } from 'three/addons/loaders/KTX2Loader.js';
import { chainToPmrem, threePmremOfMirror } from '/arlight/ArlightEstimatedLight.js';
window.renderSpheres = async (camera, spheres, baseColour) => {
  const renderer = new THREE.WebGLRenderer();
  renderer.toneMapping = THREE.NoToneMapping;
  const ktx = await new KTX2Loader().detectSupport(renderer).loadAsync('/files/specular.ktx2');
  const levels = ktx.mipmaps.map((m) => ({ face: m.width, texels: m.data }));
  const ours = chainToPmrem(renderer, levels);
  const theirs = threePmremOfMirror(renderer, ours, new THREE.PMREMGenerator(renderer));
  const { width, height } = camera;
  const target = new THREE.WebGLRenderTarget(width, height, { type: THREE.FloatType });
  const view = new THREE.PerspectiveCamera(2 * Math.atan(0.5 * height / camera.fy) * 180 / Math.PI,
    width / height, 0.1, 100);
  view.position.set(...camera.eye);
  const scene = new THREE.Scene();
  const material = new THREE.MeshStandardMaterial();
  material.color.setRGB(...baseColour);  // linear (three's working colour space)
  scene.add(new THREE.Mesh(new THREE.SphereGeometry(1, 128, 64), material));
  const result = { arlight: [], pmrem: [] };
  for (const [name, env] of [['arlight', ours.texture], ['pmrem', theirs.texture]]) {
    scene.environment = env;
    for (const s of spheres) {
      material.metalness = s.metallic;
      material.roughness = s.roughness;
      renderer.setRenderTarget(target);
      renderer.render(scene, view);
      const pixels = new Float32Array(width * height * 4);
      renderer.readRenderTargetPixels(target, 0, 0, width, height, pixels);
      result[name].push(Array.from(pixels));
    }
  }
  renderer.setRenderTarget(null);
  result.glError = renderer.getContext().getError();
  return result;
};
window.ready = true;
</script>`;

function serve() {
  const types = { '.js': 'text/javascript', '.ktx2': 'image/ktx2', '.wasm': 'application/wasm' };
  const server = http.createServer((req, res) => {
    const url = decodeURIComponent(new URL(req.url, 'http://x').pathname);
    if (url === '/') {
      res.writeHead(200, { 'content-type': 'text/html' });
      return res.end(PAGE);
    }
    let file = null;
    if (url.startsWith('/three/')) file = path.join(THREE, url.slice('/three/'.length));
    if (url.startsWith('/arlight/')) file = path.join(MODULE, path.basename(url));
    if (url.startsWith('/files/')) file = path.join(out, path.basename(url));
    if (!file || url.includes('..') || !fs.existsSync(file)) {
      res.writeHead(404);
      return res.end();
    }
    res.writeHead(200, { 'content-type': types[path.extname(file)] || 'application/octet-stream' });
    fs.createReadStream(file).pipe(res);
  });
  return new Promise((resolve) => server.listen(0, '127.0.0.1', () => resolve(server)));
}

// arlight-bench-pbr's figures for one sphere from RGBA rows read back bottom-up.
function score(reference, rgba, width, height) {
  let meanRef = 0, peak = 0;
  for (const [, , r, g, b] of reference.pixels) meanRef += r + g + b, peak = Math.max(peak, r, g, b);
  meanRef /= 3 * reference.pixels.length;
  const eps = 1e-4 * meanRef;
  let mean = 0, weighted = 0, se = 0, values = 0;
  for (const [x, y, ...want] of reference.pixels) {
    const at = 4 * ((height - 1 - y) * width + x);
    for (let c = 0; c < 3; ++c) {
      const got = rgba[at + c];
      mean += Math.abs(got - want[c]) / (want[c] + eps);
      weighted += Math.abs(got - want[c]);
      se += (got - want[c]) ** 2;
      ++values;
    }
  }
  return { mean: mean / values, weighted: weighted / values / meanRef,
    psnr_db: 10 * Math.log10((peak * peak) / Math.max(se / values, 1e-30)) };
}

execFileSync(path.join(bin, 'arlight-bench-pbr'), ['--probe', probe, '--reference',
  path.join(out, 'reference.json'), '--json', path.join(out, 'renderer.json')], { stdio: 'pipe' });
execFileSync(path.join(bin, 'arlight-maps'), ['ggx', '--input', probe, '--face', '256', '--out', out],
  { stdio: 'pipe' });
const reference = JSON.parse(fs.readFileSync(path.join(out, 'reference.json')));
const server = await serve();
const { browser, page } = await launchChromium();
try {
  await page.goto(`http://127.0.0.1:${server.address().port}/`);
  await page.waitForFunction(() => window.ready === true, null, { timeout: 60000 });
  const spheres = reference.spheres.map(({ metallic, roughness }) => ({ metallic, roughness }));
  const r = await page.evaluate(([camera, s, base]) => window.renderSpheres(camera, s, base),
    [reference.camera, spheres, reference.base_colour]);
  if (r.glError) throw new Error(`WebGL error ${r.glError}`);
  const { width, height } = reference.camera;
  const rows = reference.spheres.map((s, k) => ({
    metallic: s.metallic, roughness: s.roughness, renderer: s.renderer,
    arlight: score(s, r.arlight[k], width, height), pmrem: score(s, r.pmrem[k], width, height),
  }));
  fs.writeFileSync(path.join(out, 'three_spheres.json'),
    JSON.stringify({ probe: reference.probe, spheres: rows }, null, 1));
  const cell = (f) => `${(100 * f.mean).toFixed(1)} %; ${(100 * f.weighted).toFixed(1)} %; ${f.psnr_db.toFixed(1)} dB`;
  console.log(`| ${reference.probe} | metallic | roughness | three.js, arlight's chain as is | three.js, three's PMREM of its mirror level | arlight's renderer |`);
  console.log('|---|---|---|---|---|---|');
  for (const row of rows)
    console.log(`| | ${row.metallic} | ${row.roughness} | ${cell(row.arlight)} | ${cell(row.pmrem)} | ${cell(row.renderer)} |`);
  const avg = (key, f) => rows.reduce((s, row) => s + row[key][f], 0) / rows.length;
  console.log(`| | mean | | ${(100 * avg('arlight', 'mean')).toFixed(1)} %; ${(100 * avg('arlight', 'weighted')).toFixed(1)} %; ${avg('arlight', 'psnr_db').toFixed(1)} dB` +
    ` | ${(100 * avg('pmrem', 'mean')).toFixed(1)} %; ${(100 * avg('pmrem', 'weighted')).toFixed(1)} %; ${avg('pmrem', 'psnr_db').toFixed(1)} dB` +
    ` | ${(100 * avg('renderer', 'mean')).toFixed(1)} %; ${(100 * avg('renderer', 'weighted')).toFixed(1)} %; ${avg('renderer', 'psnr_db').toFixed(1)} dB |`);
} finally {
  await browser.close();
  server.close();
}
