// The light files arlight-maps export writes, read by the field's own tools rather than ours:
// ktx-parse (the KTX2 container), gltf-validator (the glTF), and the conventions light.json
// states checked against each other. Needs ARLIGHT_BIN and ARLIGHT_SOURCE_DIR (ctest sets them).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import { createRequire } from 'node:module';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';

const BIN = process.env.ARLIGHT_BIN;
const SOURCE = process.env.ARLIGHT_SOURCE_DIR;
const require = createRequire(path.join(SOURCE, 'client', 'web', 'package.json'));

function halfToFloat(h) {
  const s = h & 0x8000 ? -1 : 1, e = (h >> 10) & 0x1f, m = h & 0x3ff;
  if (e === 0) return s * m * 2 ** -24;
  if (e === 31) return m ? NaN : s * Infinity;
  return s * (1 + m / 1024) * 2 ** (e - 15);
}

test('export writes a KTX2 chain, light.json and a glTF the field\'s tools accept', async () => {
  const out = fs.mkdtempSync(path.join(os.tmpdir(), 'arlight-light-'));
  try {
    execFileSync(path.join(BIN, 'arlight-maps'), ['export', '--input', path.join(SOURCE, 'data/probes/park.exr'),
      '--face', '64', '--min-face', '8', '--out', out], { stdio: 'pipe' });

    const { read } = await import(require.resolve('ktx-parse'));
    const ktx = read(new Uint8Array(fs.readFileSync(path.join(out, 'specular.ktx2'))));
    assert.equal(ktx.vkFormat, 97);  // VK_FORMAT_R16G16B16A16_SFLOAT
    assert.equal(ktx.faceCount, 6);
    assert.equal(ktx.pixelWidth, 64);
    assert.equal(ktx.levels.length, 4);
    ktx.levels.forEach((l, k) => assert.equal(l.levelData.byteLength, 6 * (64 >> k) ** 2 * 8));
    const meta = JSON.parse(new TextDecoder().decode(ktx.keyValue['arlight.ggx']).replace(/\0$/, ''));
    assert.deepEqual(meta.roughness.map((r) => +r.toFixed(4)), [0, 0.1835, 0.4226, 1]);
    assert.match(meta.level_mapping, /1 - sqrt\(1 - level/);

    // The park's sky (+Y face) outshines its ground (-Y) in the roughest level, alpha is 1.
    const last = ktx.levels[3].levelData, n = 8;
    const view = new DataView(last.buffer, last.byteOffset, last.byteLength);
    const faceMean = (f) => {
      let s = 0;
      for (let t = 0; t < n * n; ++t) {
        const at = ((f * n * n) + t) * 8;
        s += halfToFloat(view.getUint16(at + 2, true));
        assert.equal(halfToFloat(view.getUint16(at + 6, true)), 1);
      }
      return s / (n * n);
    };
    assert.ok(faceMean(2) > 1.5 * faceMean(3), `sky ${faceMean(2)} vs ground ${faceMean(3)}`);

    const light = JSON.parse(fs.readFileSync(path.join(out, 'light.json'), 'utf8'));
    assert.equal(light.sh9.webxr.length, 27);
    // Filament's pre-scaling of the constant band: Y00 x A0 / pi = 0.282095.
    assert.ok(Math.abs(light.sh9.filament[1] - light.sh9.webxr[1] * 0.2820948) < 1e-5 * Math.abs(light.sh9.webxr[1]));
    // Unity mirrors z: (1,0) negated, (1,1) kept.
    assert.equal(light.sh9.unity.g[2], -light.sh9.webxr[3 * 2 + 1]);
    assert.equal(light.sh9.unity.g[3], light.sh9.webxr[3 * 3 + 1]);
    assert.ok(Math.abs(Math.hypot(...light.primary_light.direction) - 1) < 1e-4);
    // The park's sun, low in the sky (the light tree's brightest cluster: ~14 degrees up, south-west
    // of -Z), white-ish once the blue channel's compression ringing is limited.
    assert.ok(light.primary_light.direction[1] > 0.15, 'the park\'s light comes from above');
    const [r, g, b] = light.primary_light.intensity;
    assert.ok(b < 2 * r && r > 0, `the primary light's colour is not the blue ringing: ${r} ${g} ${b}`);
    assert.equal(light.specular.levels.length, 4);

    const validator = require('gltf-validator');
    const gltf = fs.readFileSync(path.join(out, 'lighting.gltf'));
    const report = await validator.validateBytes(new Uint8Array(gltf), {
      uri: 'lighting.gltf',
      externalResourceFunction: (uri) => Promise.resolve(new Uint8Array(fs.readFileSync(path.join(out, decodeURIComponent(uri))))),
    });
    assert.equal(report.issues.numErrors, 0, JSON.stringify(report.issues.messages.slice(0, 5)));
    assert.equal(report.issues.numWarnings, 0, JSON.stringify(report.issues.messages.slice(0, 5)));
    const ibl = JSON.parse(gltf).extensions.EXT_lights_image_based.lights[0];
    assert.equal(ibl.specularImageSize, 64);
    assert.equal(ibl.specularImages.length, 4);
    assert.equal(ibl.irradianceCoefficients.length, 9);
  } finally {
    fs.rmSync(out, { recursive: true, force: true });
  }
});

// issue 51 §1: export --lights takes studio's ring light out of the SH and the chain and writes
// it as a directional light (light.json lights, lighting.gltf KHR_lights_punctual, which the
// validator accepts): the residual's SH plus the light's is the whole room's, and the light's node
// turns +Z (its -Z shines) towards the light.
test('export --lights writes the lights apart, the SH and chain of the rest', async () => {
  const out = fs.mkdtempSync(path.join(os.tmpdir(), 'arlight-light-'));
  try {
    const exportRoom = (dir, extra) => execFileSync(path.join(BIN, 'arlight-maps'), ['export', '--input',
      path.join(SOURCE, 'data/probes/studio.exr'), '--face', '32', '--min-face', '8', '--out', dir, ...extra],
    { stdio: 'pipe' });
    exportRoom(path.join(out, 'whole'), []);
    exportRoom(path.join(out, 'apart'), ['--lights', '8']);
    const whole = JSON.parse(fs.readFileSync(path.join(out, 'whole', 'light.json'), 'utf8'));
    const apart = JSON.parse(fs.readFileSync(path.join(out, 'apart', 'light.json'), 'utf8'));
    assert.equal(whole.lights, undefined);
    const lights = apart.lights.directional;
    assert.equal(lights.length, 1, JSON.stringify(lights));
    assert.match(apart.sh9.holds, /less lights/);
    // SH of a light of power P at d: P Y_lm(d); the constant band Y00 = 0.282095.
    for (let c = 0; c < 3; ++c) {
      const sum = apart.sh9.webxr[c] + lights.reduce((s, l) => s + 0.2820948 * l.intensity[c], 0);
      assert.ok(Math.abs(sum - whole.sh9.webxr[c]) < 1e-3 * whole.sh9.webxr[c], `channel ${c}: ${sum} vs ${whole.sh9.webxr[c]}`);
    }
    assert.deepEqual(apart.primary_light, whole.primary_light);

    const validator = require('gltf-validator');
    const dir = path.join(out, 'apart');
    const gltf = fs.readFileSync(path.join(dir, 'lighting.gltf'));
    const report = await validator.validateBytes(new Uint8Array(gltf), {
      uri: 'lighting.gltf',
      externalResourceFunction: (uri) => Promise.resolve(new Uint8Array(fs.readFileSync(path.join(dir, decodeURIComponent(uri))))),
    });
    assert.equal(report.issues.numErrors, 0, JSON.stringify(report.issues.messages.slice(0, 5)));
    const doc = JSON.parse(gltf);
    const light = doc.extensions.KHR_lights_punctual.lights[0];
    assert.equal(light.type, 'directional');
    const [x, y, z, w] = doc.nodes[0].rotation;
    // +Z rotated by (x, y, z, w): the third column of its rotation matrix.
    const turned = [2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)];
    turned.forEach((v, i) => assert.ok(Math.abs(v - lights[0].direction[i]) < 1e-5, `${turned} vs ${lights[0].direction}`));
    assert.ok(Math.abs(light.intensity * light.color[0] - lights[0].intensity[0]) < 1e-4 * lights[0].intensity[0]);
  } finally {
    fs.rmSync(out, { recursive: true, force: true });
  }
});

test('export refuses a face that is not a power of two, naming it', () => {
  const out = fs.mkdtempSync(path.join(os.tmpdir(), 'arlight-light-'));
  try {
    assert.throws(() => execFileSync(path.join(BIN, 'arlight-maps'), ['export', '--input',
      path.join(SOURCE, 'data/probes/park.exr'), '--face', '100', '--out', out], { stdio: 'pipe' }),
    (e) => e.status === 2 && /power of two, got 100/.test(e.stderr.toString()));
    assert.equal(fs.existsSync(path.join(out, 'specular.ktx2')), false);
  } finally {
    fs.rmSync(out, { recursive: true, force: true });
  }
});

// arlight's textured test model as arlight-model writes it (and the copy committed in
// data/models): gltf-validator (the Khronos validator, npm, pinned) finds no error and no
// warning, and sees the two materials with their four textures.
test('the textured test model arlight-model writes is valid glTF', async () => {
  const out = fs.mkdtempSync(path.join(os.tmpdir(), 'arlight-model-'));
  try {
    const file = path.join(out, 'tiles.glb');
    execFileSync(path.join(BIN, 'arlight-model'), ['sample', file, '--texture-size', '64'], { stdio: 'pipe' });
    const validator = require('gltf-validator');
    for (const glb of [file, path.join(SOURCE, 'data/models/tiles.glb')]) {
      const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(glb)), { uri: 'tiles.glb' });
      assert.equal(report.issues.numErrors, 0, JSON.stringify(report.issues.messages.slice(0, 5)));
      assert.equal(report.issues.numWarnings, 0, JSON.stringify(report.issues.messages.slice(0, 5)));
      assert.equal(report.info.materialCount, 2);
      assert.equal(report.info.resources.filter((r) => r.image && r.mimeType === 'image/png').length, 4);
    }
  } finally {
    fs.rmSync(out, { recursive: true, force: true });
  }
});
