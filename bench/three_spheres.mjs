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
import { scoreCell, scoreSphere } from '../tests/web/sphere_scores.mjs';

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
import { renderSpheresLinear } from '/web/sphere_grid.js';
window.renderSpheres = async (camera, spheres, baseColour) => {
  const renderer = new THREE.WebGLRenderer();
  renderer.toneMapping = THREE.NoToneMapping;
  const ktx = await new KTX2Loader().detectSupport(renderer).loadAsync('/files/specular.ktx2');
  const levels = ktx.mipmaps.map((m) => ({ face: m.width, texels: m.data }));
  const ours = chainToPmrem(renderer, levels);
  const theirs = threePmremOfMirror(renderer, ours, new THREE.PMREMGenerator(renderer));
  const result = {};
  for (const [name, env] of [['arlight', ours.texture], ['pmrem', theirs.texture]])
    result[name] = renderSpheresLinear(renderer, env, camera, spheres, baseColour).map((p) => Array.from(p));
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
    if (url.startsWith('/web/')) file = path.join(ROOT, 'client', 'web', 'src', path.basename(url));
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
    arlight: scoreSphere(s, r.arlight[k], width, height), pmrem: scoreSphere(s, r.pmrem[k], width, height),
  }));
  fs.writeFileSync(path.join(out, 'three_spheres.json'),
    JSON.stringify({ probe: reference.probe, spheres: rows }, null, 1));
  const cell = scoreCell;
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
