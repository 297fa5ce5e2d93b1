// The page composites the same pixels as the native client: the page's WebAssembly renderer in
// headless Chromium (WebGL2 on SwiftShader) and the native renderer (GLES on Mesa's llvmpipe)
// draw the bunny (and the textured tiled ball with its own materials) over the same frame with the same lighting (a LightingUpdate of venice's SH,
// given to the page's WebClient.receive()) and the view the page reports (WebClient.view()), in
// each compositing mode the page offers. Both are the same C++ and shaders; what may differ is
// the two GPUs' arithmetic, so the object's pixels must agree within a quarter of a code on
// average and 2 codes at the 99th percentile (glass: 1 code, and 4 at the 95th), and the
// frame's pixels around it exactly. Run by ctest (tests/web/web_tests.cmake).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';

import { launchChromium } from './harness.mjs';
import { startDaemon } from './phone_session.mjs';

const BIN = process.env.ARLIGHT_BIN;
const SOURCE = process.env.ARLIGHT_SOURCE_DIR;
const REFERENCE = process.env.ARLIGHT_WEB_PIXEL_REFERENCE;
const W = 320;
const H = 240;

const MODES = [
  { model: 'bunny', material: 'plastic', shading: 'maps', refraction: 'live', colour: 'none' },
  { model: 'bunny', material: 'metal', shading: 'hemisphere-occlusion', refraction: 'live', colour: 'none' },
  { model: 'bunny', material: 'glass', shading: 'maps', refraction: 'live', colour: 'none' },
  { model: 'bunny', material: 'matte', shading: 'maps', refraction: 'live', colour: 'match' },
  // The textured glTF metallic-roughness model with its own materials: its PNG textures decoded
  // by the page's WebAssembly (stb_image) and natively, its two parts each with its material.
  { model: 'tiles', material: 'model', shading: 'maps', refraction: 'live', colour: 'none' },
];

// A frame of smooth colour waves (RGB, row 0 at the top): refraction and colour errors show.
function waveFrame() {
  const rgb = new Uint8Array(W * H * 3);
  for (let y = 0; y < H; ++y) {
    for (let x = 0; x < W; ++x) {
      const i = 3 * (y * W + x);
      rgb[i] = 128 + 90 * Math.sin((2 * Math.PI * x) / 37);
      rgb[i + 1] = 128 + 90 * Math.sin((2 * Math.PI * y) / 29);
      rgb[i + 2] = 128 + 90 * Math.sin((2 * Math.PI * (x + y)) / 53);
    }
  }
  return rgb;
}

// Binary PPM (P6, RGB) and PGM (P5) files, which the native helper's OpenCV reads and writes.
function writePpm(file, rgb) {
  fs.writeFileSync(file, Buffer.concat([Buffer.from(`P6\n${W} ${H}\n255\n`), Buffer.from(rgb)]));
}
function readPnm(file) {
  const data = fs.readFileSync(file);
  let pos = 0;
  const fields = [];
  while (fields.length < 4) {
    while (/\s/.test(String.fromCharCode(data[pos]))) ++pos;
    let s = '';
    while (!/\s/.test(String.fromCharCode(data[pos]))) s += String.fromCharCode(data[pos++]);
    fields.push(s);
  }
  ++pos;  // the single whitespace after the maximum
  return { channels: fields[0] === 'P6' ? 3 : 1, pixels: data.subarray(pos) };
}

test('the page composites the same pixels as the native renderer, in every mode', { timeout: 300000 }, async () => {
  assert.ok(BIN && SOURCE && REFERENCE, 'ARLIGHT_BIN, ARLIGHT_SOURCE_DIR and ARLIGHT_WEB_PIXEL_REFERENCE must be set (ctest does)');
  const dir = fs.mkdtempSync(path.join(os.tmpdir(), 'arlight-page-pixels-'));
  const lighting = path.join(dir, 'lighting.bin');
  execFileSync(REFERENCE, ['lighting', path.join(SOURCE, 'data/probes/venice.exr'), lighting]);
  const frame = waveFrame();
  const framePpm = path.join(dir, 'frame.ppm');
  writePpm(framePpm, frame);

  const d = await startDaemon({ bin: BIN, dir: path.join(dir, 'daemon'), webRoot: path.join(BIN, 'web'), token: 'pixels-token-0123456789' });
  const { browser, page } = await launchChromium();
  try {
    const pageErrors = [];
    page.on('pageerror', (e) => pageErrors.push(e.message));
    await page.goto(`${new URL(d.url).origin}/`);
    // The page's own module and WebClient on a canvas of their own; the frame goes into the
    // camera texture as the page's upload does, and the canvas is read back after each render.
    const results = await page.evaluate(async ({ w, h, lightingBytes, frameRgb, modes }) => {
      const { default: createArlight } = await import('/arlight_web.js');
      const m = await createArlight();
      const canvas = document.createElement('canvas');
      canvas.id = 'pixels';
      canvas.width = w;
      canvas.height = h;
      document.body.appendChild(canvas);
      const client = new m.WebClient('#pixels', w, h);
      client.setFov(30);  // the preview object fills more of the view
      let model = null;
      if (client.receive(new Uint8Array(lightingBytes)) !== 'LightingUpdate') throw new Error('lighting refused');
      const gl = m.GL.currentContext.GLctx;
      const out = [];
      for (const mode of modes) {
        if (mode.model !== model) {
          model = mode.model;
          const glb = new Uint8Array(await (await fetch(`/models/${model}.glb`)).arrayBuffer());
          const error = client.setModel(model, glb);
          if (error) throw new Error(error);
        }
        client.setMaterial(mode.material);
        client.setShading(mode.shading);
        client.setRefraction(mode.refraction);
        client.setColour(mode.colour);
        gl.bindTexture(gl.TEXTURE_2D, m.GL.textures[client.cameraTexture()]);
        gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
        gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, w, h, gl.RGB, gl.UNSIGNED_BYTE, new Uint8Array(frameRgb));
        gl.pixelStorei(gl.UNPACK_ALIGNMENT, 4);
        // The camera turned 12 degrees down from level: the preview object ahead, below centre.
        const a = (-12 * Math.PI) / 180 / 2;
        client.render(1.0, Math.cos(a), Math.sin(a), 0, 0);
        const rgba = new Uint8Array(w * h * 4);
        gl.bindFramebuffer(gl.FRAMEBUFFER, null);
        gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, rgba);
        out.push({ view: client.view(), camera: client.camera(), rgba: Array.from(rgba) });
      }
      return out;
    }, { w: W, h: H, lightingBytes: Array.from(fs.readFileSync(lighting)), frameRgb: Array.from(frame), modes: MODES });
    assert.deepEqual(pageErrors, []);

    for (const [k, r] of results.entries()) {
      const name = Object.values(MODES[k]).join('/');
      assert.ok(r.view, `${name}: the page drew nothing`);
      fs.writeFileSync(path.join(dir, `view${k}.json`), JSON.stringify({ view: r.view, camera: r.camera }));
      const nativePpm = path.join(dir, `native${k}.ppm`);
      execFileSync(REFERENCE, ['render', lighting, path.join(dir, `view${k}.json`), framePpm,
        path.join(BIN, 'web', 'models', `${MODES[k].model}.glb`), nativePpm]);
      const native = readPnm(nativePpm).pixels;
      const mask = readPnm(path.join(dir, `native${k}_mask.pgm`)).pixels;
      // The canvas read back bottom row first.
      const pagePx = (x, y, c) => r.rgba[4 * ((H - 1 - y) * W + x) + c];
      const near = (x, y) => {  // a pixel of the object's edge: rasterisers may differ there
        for (let dy = -1; dy <= 1; ++dy) {
          for (let dx = -1; dx <= 1; ++dx) {
            const xx = Math.min(W - 1, Math.max(0, x + dx));
            const yy = Math.min(H - 1, Math.max(0, y + dy));
            if (mask[yy * W + xx] !== mask[y * W + x]) return true;
          }
        }
        return false;
      };
      const diffs = [];
      let outsideChanged = 0;
      let inside = 0;
      for (let y = 0; y < H; ++y) {
        for (let x = 0; x < W; ++x) {
          if (near(x, y)) continue;
          if (mask[y * W + x]) {
            ++inside;
            for (let c = 0; c < 3; ++c) diffs.push(Math.abs(pagePx(x, y, c) - native[3 * (y * W + x) + c]));
          } else {
            for (let c = 0; c < 3; ++c) outsideChanged += pagePx(x, y, c) !== frame[3 * (y * W + x) + c];
          }
        }
      }
      diffs.sort((a, b) => a - b);
      const mean = diffs.reduce((s, v) => s + v, 0) / diffs.length;
      const p95 = diffs[Math.floor(0.95 * (diffs.length - 1))];
      const p99 = diffs[Math.floor(0.99 * (diffs.length - 1))];
      console.log(`${name}: ${inside} object pixels, page vs native mean ${mean.toFixed(2)} codes, p95 ${p95}, p99 ${p99}, max ${diffs[diffs.length - 1]}`);
      assert.ok(inside > 2000, `${name}: only ${inside} object pixels`);
      // Glass shows the frame where refracted rays land: where they leave the frame (the maps
      // then) or graze the floor, a last-bit difference in the ray switches what a pixel shows,
      // so its tail is wider.
      const [meanTol, tailTol, tail] = MODES[k].material === 'glass' ? [1.0, 4, p95] : [0.25, 2, p99];
      assert.ok(mean <= meanTol, `${name}: the page's object is ${mean.toFixed(2)} codes from the native one on average`);
      assert.ok(tail <= tailTol, `${name}: the tail of the object's pixels is ${tail} codes from the native ones`);
      assert.equal(outsideChanged, 0, `${name}: the page changed ${outsideChanged} frame values around the object`);
    }
  } finally {
    await browser.close();
    await d.stop();
  }
});
