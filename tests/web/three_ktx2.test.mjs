// specular.ktx2 in a real browser: three.js's own KTX2Loader (npm `three`, pinned) parses what
// arlight-maps ggx writes in headless Chromium, the levels go to WebGL2 as a cube map, and
// sampling that cube with GLSL's textureLod(samplerCube, d, level) gives what the file holds for
// d by common/CONVENTIONS.md's cube table: the face order and texel orientation engines assume.
// Needs ARLIGHT_BIN and ARLIGHT_SOURCE_DIR (ctest sets them).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import http from 'node:http';
import os from 'node:os';
import path from 'node:path';

import { cubeTexel, halfRgbaTexel } from './cube_texels.mjs';
import { WEB_ROOT, launchChromium } from './harness.mjs';

const BIN = process.env.ARLIGHT_BIN;
const SOURCE = process.env.ARLIGHT_SOURCE_DIR;
const THREE_ROOT = path.join(WEB_ROOT, 'node_modules', 'three');

const PAGE = `<!doctype html><meta charset="utf-8">
<script type="importmap">{"imports": {"three": "/three/build/three.module.js",
  "three/addons/": "/three/examples/jsm/"}}</script>
<script type="module">
import * as THREE from 'three';
import { KTX2Loader } from 'three/addons/loaders/KTX2Loader.js';
window.sampleChain = async (url, dirs) => {
  const renderer = new THREE.WebGLRenderer();
  const tex = await new KTX2Loader().detectSupport(renderer).loadAsync(url);
  // three r187 makes uncompressed KTX2 cubes a DataTexture whose levels hold the six faces one
  // after another; split them into a cube texture (uploaded with texImage2D for RGBA).
  const faces = [0, 1, 2, 3, 4, 5].map((f) => ({
    width: tex.image.width, height: tex.image.height,
    mipmaps: tex.mipmaps.map((m) => ({ width: m.width, height: m.height,
      data: m.data.subarray(f * m.data.length / 6, (f + 1) * m.data.length / 6) })),
  }));
  const cube = new THREE.CompressedCubeTexture(faces, THREE.RGBAFormat, THREE.HalfFloatType);
  cube.minFilter = THREE.NearestMipmapNearestFilter;
  cube.magFilter = THREE.NearestFilter;
  cube.generateMipmaps = false;
  cube.needsUpdate = true;
  // One output pixel per (direction, level): textureLod at the texel's direction.
  const n = dirs.length;
  const target = new THREE.WebGLRenderTarget(n, 1, { type: THREE.FloatType });
  const dirData = new Float32Array(n * 4);
  dirs.forEach((d, i) => dirData.set([d[0], d[1], d[2], d[3]], 4 * i));
  const dirTex = new THREE.DataTexture(dirData, n, 1, THREE.RGBAFormat, THREE.FloatType);
  dirTex.needsUpdate = true;
  const material = new THREE.RawShaderMaterial({
    glslVersion: THREE.GLSL3,
    uniforms: { chain: { value: cube }, dirs: { value: dirTex } },
    vertexShader: 'in vec3 position; void main() { gl_Position = vec4(position.xy, 0.0, 1.0); }',
    fragmentShader: \`precision highp float; uniform samplerCube chain; uniform sampler2D dirs;
      out vec4 colour;
      void main() { vec4 d = texelFetch(dirs, ivec2(gl_FragCoord.xy), 0);
        colour = textureLod(chain, d.xyz, d.w); }\`,
  });
  const scene = new THREE.Scene();
  scene.add(new THREE.Mesh(new THREE.PlaneGeometry(2, 2), material));
  renderer.setRenderTarget(target);
  renderer.render(scene, new THREE.Camera());
  const out = new Float32Array(n * 4);
  renderer.readRenderTargetPixels(target, 0, 0, n, 1, out);
  return { levels: tex.mipmaps.length, type: tex.type, format: tex.format, width: tex.image.width,
           halfFloat: THREE.HalfFloatType, rgba: THREE.RGBAFormat, glError: renderer.getContext().getError(),
           values: Array.from(out) };
};
window.ready = true;
</script>`;

function serve(dir) {
  const types = { '.js': 'text/javascript', '.ktx2': 'image/ktx2', '.html': 'text/html' };
  const server = http.createServer((req, res) => {
    const url = decodeURIComponent(new URL(req.url, 'http://x').pathname);
    let file = null;
    if (url === '/') {
      res.writeHead(200, { 'content-type': 'text/html' });
      return res.end(PAGE);
    }
    if (url.startsWith('/three/')) file = path.join(THREE_ROOT, url.slice('/three/'.length));
    if (url.startsWith('/files/')) file = path.join(dir, path.basename(url));
    if (!file || file.includes('..') || !fs.existsSync(file)) {
      res.writeHead(404);
      return res.end();
    }
    res.writeHead(200, { 'content-type': types[path.extname(file)] || 'application/octet-stream' });
    fs.createReadStream(file).pipe(res);
  });
  return new Promise((resolve) => server.listen(0, '127.0.0.1', () => resolve(server)));
}

// The file's texel for direction d at a level.
function fileTexel(ktx, level, face0, d) {
  const n = face0 >> level;
  const data = ktx.levels[level].levelData;
  return halfRgbaTexel(new DataView(data.buffer, data.byteOffset, data.byteLength), n, cubeTexel(n, d));
}

test('three.js KTX2Loader loads specular.ktx2 and WebGL samples it as the file says', async () => {
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'arlight-three-ktx2-'));
  const server = await serve(dir);
  let browser;
  try {
    execFileSync(path.join(BIN, 'arlight-maps'), ['ggx', '--input', path.join(SOURCE, 'data/probes/park.exr'),
      '--face', '32', '--min-face', '4', '--out', dir], { stdio: 'pipe' });
    const { read } = await import(path.join(WEB_ROOT, 'node_modules', 'ktx-parse', 'dist', 'index.mjs'));
    const ktx = read(new Uint8Array(fs.readFileSync(path.join(dir, 'specular.ktx2'))));
    // Directions inside texels (not on their edges), on every face, at every level.
    const dirs = [];
    const axes = [[1, 0.31, -0.2], [-1, 0.27, 0.44], [0.15, 1, -0.37], [0.42, -1, 0.1], [-0.33, 0.21, 1], [0.12, -0.45, -1]];
    for (let level = 0; level < 4; ++level) for (const a of axes) dirs.push([...a, level]);
    ({ browser } = await launchChromium());
    const page = (await browser.contexts())[0].pages()[0];
    await page.goto(`http://127.0.0.1:${server.address().port}/`);
    await page.waitForFunction(() => window.ready === true, null, { timeout: 60000 });
    const r = await page.evaluate(([d]) => window.sampleChain('/files/specular.ktx2', d), [dirs]);
    assert.equal(r.levels, 4);
    assert.equal(r.width, 32);
    assert.equal(r.type, r.halfFloat);
    assert.equal(r.format, r.rgba);
    assert.equal(r.glError, 0);
    dirs.forEach((d, k) => {
      const want = fileTexel(ktx, d[3], 32, d.slice(0, 3));
      for (let c = 0; c < 3; ++c) {
        const got = r.values[4 * k + c];
        assert.ok(Math.abs(got - want[c]) <= 1e-3 * Math.abs(want[c]) + 1e-6,
          `level ${d[3]} direction ${d.slice(0, 3)} channel ${c}: WebGL ${got}, file ${want[c]}`);
      }
    });
    // And the values are the park's, not zeros: the sky above outshines the ground below.
    assert.ok(r.values[4 * 2 + 1] > r.values[4 * 3 + 1], 'sky brighter than ground at level 0');
  } finally {
    if (browser) await browser.close();
    server.close();
    fs.rmSync(dir, { recursive: true, force: true });
  }
});
