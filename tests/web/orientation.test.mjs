// Unit tests for client/web/src/orientation.js. Run from the repository root:
//   node --test tests/web/
// World frame used by the conversion: +X East, +Y Up, −Z North. ENU: X East, Y North, Z Up.

import test from 'node:test';
import assert from 'node:assert/strict';

import {
  cameraQuatFromSensorQuaternion,
  cameraQuatFromDeviceOrientation,
  sensorQuaternionFromCameraQuat,
  cameraToDeviceQuat,
  deviceQuatFromEuler,
  quatMultiply,
  quatConjugate,
  quatNormalize,
  quatRotateVector,
  quatFromAxisAngle,
  OrientationHistory,
  normalizeScreenAngle,
  Q_ENU_TO_WORLD,
} from '../../client/web/src/orientation.js';

const TOL = 1e-9;
const SCREEN_ANGLES = [0, 90, 180, 270];

// World directions.
const EAST = [1, 0, 0];
const WEST = [-1, 0, 0];
const UP = [0, 1, 0];
const DOWN = [0, -1, 0];
const NORTH = [0, 0, -1];
const SOUTH = [0, 0, 1];

// Camera axes.
const CAM_RIGHT = [1, 0, 0];
const CAM_UP = [0, 1, 0];
const CAM_FORWARD = [0, 0, -1];

function assertVecClose(actual, expected, what, tol = TOL) {
  assert.equal(actual.length, expected.length, `${what}: length`);
  for (let i = 0; i < expected.length; i++) {
    assert.ok(
      Math.abs(actual[i] - expected[i]) <= tol,
      `${what}: got [${actual.join(', ')}], expected [${expected.join(', ')}] (component ${i})`,
    );
  }
}

/** q and −q are the same rotation: compare with the sign that matches. */
function assertSameRotation(a, b, what, tol = TOL) {
  const dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
  const s = dot < 0 ? -1 : 1;
  assertVecClose(a, b.map((v) => v * s), what, tol);
}

function assertUnitCanonical(q, what) {
  const n = Math.hypot(...q);
  assert.ok(Math.abs(n - 1) <= TOL, `${what}: norm ${n}`);
}

/** Deterministic PRNG (mulberry32) so a failure is reproducible. */
function rng(seed) {
  let a = seed >>> 0;
  return () => {
    a = (a + 0x6d2b79f5) >>> 0;
    let t = a;
    t = Math.imul(t ^ (t >>> 15), t | 1);
    t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  };
}

function randomUnitQuatWXYZ(rand) {
  for (;;) {
    const q = [rand() * 2 - 1, rand() * 2 - 1, rand() * 2 - 1, rand() * 2 - 1];
    const n = Math.hypot(...q);
    if (n > 0.1 && n <= 1) return q.map((v) => v / n);
  }
}

/**
 * Independent of the module: the W3C Orientation Sensor spec's Euler → quaternion formula for
 * R = Rz(alpha) Rx(beta) Ry(gamma), returning [x, y, z, w].
 */
function specSensorQuaternion(alpha, beta, gamma) {
  const d = Math.PI / 180;
  const _x = beta * d;
  const _y = gamma * d;
  const _z = alpha * d;
  const cX = Math.cos(_x / 2);
  const cY = Math.cos(_y / 2);
  const cZ = Math.cos(_z / 2);
  const sX = Math.sin(_x / 2);
  const sY = Math.sin(_y / 2);
  const sZ = Math.sin(_z / 2);
  const w = cX * cY * cZ - sX * sY * sZ;
  const x = sX * cY * cZ - cX * sY * sZ;
  const y = cX * sY * cZ + sX * cY * sZ;
  const z = cX * cY * sZ + sX * sY * cZ;
  return [x, y, z, w];
}

/** Independent of the module: the DeviceOrientation spec's rotation matrix (device → ENU). */
function specRotationMatrix(alpha, beta, gamma) {
  const d = Math.PI / 180;
  const cA = Math.cos(alpha * d);
  const sA = Math.sin(alpha * d);
  const cB = Math.cos(beta * d);
  const sB = Math.sin(beta * d);
  const cG = Math.cos(gamma * d);
  const sG = Math.sin(gamma * d);
  return [
    [cA * cG - sA * sB * sG, -cB * sA, cG * sA * sB + cA * sG],
    [cG * sA + cA * sB * sG, cA * cB, sA * sG - cA * cG * sB],
    [-cB * sG, sB, cB * cG],
  ];
}

function matVec(m, v) {
  return m.map((row) => row[0] * v[0] + row[1] * v[1] + row[2] * v[2]);
}

/**
 * Independent of the module: a [x, y, z, w] sensor quaternion for a device pose given by where
 * the device's x, y, z axes point in ENU (the columns of the rotation matrix). Shepperd's method.
 */
function sensorQuatFromDeviceAxesENU(xAxis, yAxis, zAxis) {
  const m = [
    [xAxis[0], yAxis[0], zAxis[0]],
    [xAxis[1], yAxis[1], zAxis[1]],
    [xAxis[2], yAxis[2], zAxis[2]],
  ];
  const tr = m[0][0] + m[1][1] + m[2][2];
  let w;
  let x;
  let y;
  let z;
  if (tr > 0) {
    const s = Math.sqrt(tr + 1) * 2;
    w = s / 4;
    x = (m[2][1] - m[1][2]) / s;
    y = (m[0][2] - m[2][0]) / s;
    z = (m[1][0] - m[0][1]) / s;
  } else if (m[0][0] > m[1][1] && m[0][0] > m[2][2]) {
    const s = Math.sqrt(1 + m[0][0] - m[1][1] - m[2][2]) * 2;
    w = (m[2][1] - m[1][2]) / s;
    x = s / 4;
    y = (m[0][1] + m[1][0]) / s;
    z = (m[0][2] + m[2][0]) / s;
  } else if (m[1][1] > m[2][2]) {
    const s = Math.sqrt(1 + m[1][1] - m[0][0] - m[2][2]) * 2;
    w = (m[0][2] - m[2][0]) / s;
    x = (m[0][1] + m[1][0]) / s;
    y = s / 4;
    z = (m[1][2] + m[2][1]) / s;
  } else {
    const s = Math.sqrt(1 + m[2][2] - m[0][0] - m[1][1]) * 2;
    w = (m[1][0] - m[0][1]) / s;
    x = (m[0][2] + m[2][0]) / s;
    y = (m[1][2] + m[2][1]) / s;
    z = s / 4;
  }
  return [x, y, z, w];
}

// ENU unit vectors for building physical poses.
const ENU_E = [1, 0, 0];
const ENU_W = [-1, 0, 0];
const ENU_N = [0, 1, 0];
const ENU_S = [0, -1, 0];
const ENU_U = [0, 0, 1];
const ENU_D = [0, 0, -1];

function assertCameraPointing(q, { forward, up, right }, what) {
  assertUnitCanonical(q, what);
  assertVecClose(quatRotateVector(q, CAM_FORWARD), forward, `${what}: viewing direction`);
  assertVecClose(quatRotateVector(q, CAM_UP), up, `${what}: image up`);
  assertVecClose(quatRotateVector(q, CAM_RIGHT), right, `${what}: image right`);
}

// ---------------------------------------------------------------------------------------------
// Helpers

test('quaternion helpers: product, rotation, normalisation, canonical sign', () => {
  const qz90 = quatFromAxisAngle([0, 0, 1], 90);
  assertVecClose(qz90, [Math.SQRT1_2, 0, 0, Math.SQRT1_2], 'Rz(90)');
  assertVecClose(quatRotateVector(qz90, [1, 0, 0]), [0, 1, 0], 'Rz(90) x');
  const qx90 = quatFromAxisAngle([1, 0, 0], 90);
  assertVecClose(quatRotateVector(qx90, [0, 1, 0]), [0, 0, 1], 'Rx(90) y');
  // a ⊗ b applies b first: Rz(90) ⊗ Rx(90) sends y → z (by Rx) → z (Rz fixes z).
  const ab = quatMultiply(qz90, qx90);
  assertVecClose(quatRotateVector(ab, [0, 1, 0]), [0, 0, 1], 'Rz⊗Rx y');
  assertVecClose(quatRotateVector(ab, [0, 0, 1]), [1, 0, 0], 'Rz⊗Rx z');
  assertVecClose(quatMultiply(ab, quatConjugate(ab)), [1, 0, 0, 0], 'q ⊗ q*');
  assertVecClose(quatNormalize([-2, 0, 0, 0]), [1, 0, 0, 0], 'normalise flips sign');
  assertVecClose(quatNormalize([0, -3, 4, 0]), [0, 0.6, -0.8, 0], 'w = 0: first non-zero positive');
  assert.throws(() => quatNormalize([0, 0, 0, 0]), RangeError);
  assert.throws(() => quatNormalize([NaN, 0, 0, 1]), RangeError);
  assert.equal(normalizeScreenAngle(-90), 270);
  assert.equal(normalizeScreenAngle(450), 90);
  assert.throws(() => normalizeScreenAngle(undefined), RangeError);
  assert.throws(() => cameraQuatFromDeviceOrientation(null, 0, 0, 0), RangeError);
  assert.throws(() => cameraQuatFromSensorQuaternion([0, 0, 1], 0), RangeError);
});

test('ENU → world: East ↦ +X, North ↦ −Z, Up ↦ +Y, and the world frame is right-handed', () => {
  assertVecClose(quatRotateVector(Q_ENU_TO_WORLD, ENU_E), EAST, 'East');
  assertVecClose(quatRotateVector(Q_ENU_TO_WORLD, ENU_N), NORTH, 'North');
  assertVecClose(quatRotateVector(Q_ENU_TO_WORLD, ENU_U), UP, 'Up');
  // E × U = −N: (1,0,0) × (0,1,0) = (0,0,1) = South.
  const cross = [
    EAST[1] * UP[2] - EAST[2] * UP[1],
    EAST[2] * UP[0] - EAST[0] * UP[2],
    EAST[0] * UP[1] - EAST[1] * UP[0],
  ];
  assertVecClose(cross, SOUTH, 'E × U');
});

// ---------------------------------------------------------------------------------------------
// Physical poses

test('flat on a table, screen up: rear camera looks down, image up is North', () => {
  for (const q of [
    cameraQuatFromDeviceOrientation(0, 0, 0, 0),
    cameraQuatFromSensorQuaternion([0, 0, 0, 1], 0),
  ]) {
    assertCameraPointing(q, { forward: DOWN, up: NORTH, right: EAST }, 'flat');
  }
});

test('upright portrait (beta = 90): alpha = 0 looks North, alpha = 90 looks West', () => {
  assertCameraPointing(
    cameraQuatFromDeviceOrientation(0, 90, 0, 0),
    { forward: NORTH, up: UP, right: EAST },
    'portrait alpha=0',
  );
  // alpha = 90: turned counter-clockwise seen from above, the back faces West.
  assertCameraPointing(
    cameraQuatFromDeviceOrientation(90, 90, 0, 0),
    { forward: WEST, up: UP, right: NORTH },
    'portrait alpha=90',
  );
  // The same portrait pose from the sensor path, built from physical axes:
  // device x → East, y → Up, z (screen normal) → South.
  assertCameraPointing(
    cameraQuatFromSensorQuaternion(sensorQuatFromDeviceAxesENU(ENU_E, ENU_U, ENU_S), 0),
    { forward: NORTH, up: UP, right: EAST },
    'portrait from axes',
  );
});

test('screen-angle rule: camera → device is Rz(−θ) (θ = 90: image up = device +x, right = device −y)', () => {
  // Columns of R_CD: where the image axes point in device coordinates.
  const expected = {
    0: { right: [1, 0, 0], up: [0, 1, 0] },
    90: { right: [0, -1, 0], up: [1, 0, 0] }, // top of the phone to the LEFT
    180: { right: [-1, 0, 0], up: [0, -1, 0] }, // upside down
    270: { right: [0, 1, 0], up: [-1, 0, 0] }, // top of the phone to the RIGHT
  };
  for (const theta of SCREEN_ANGLES) {
    const q = cameraToDeviceQuat(theta);
    assertVecClose(quatRotateVector(q, CAM_RIGHT), expected[theta].right, `θ=${theta} image right`);
    assertVecClose(quatRotateVector(q, CAM_UP), expected[theta].up, `θ=${theta} image up`);
    assertVecClose(quatRotateVector(q, CAM_FORWARD), [0, 0, -1], `θ=${theta} rear camera on −z`);
  }
});

test('landscape, top to the left (θ = 90), upright facing North: looks North, up +Y, right East', () => {
  // Device turned 90° counter-clockwise (seen by the user) from upright portrait facing North:
  // device x → Up, device y (top) → West (the user's left), screen normal z → South.
  const sensor = sensorQuatFromDeviceAxesENU(ENU_U, ENU_W, ENU_S);
  const want = { forward: NORTH, up: UP, right: EAST };
  assertCameraPointing(cameraQuatFromSensorQuaternion(sensor, 90), want, 'landscape θ=90 sensor');
  // The same pose as deviceorientation angles: alpha = 90, beta = 0, gamma = −90.
  assertCameraPointing(cameraQuatFromDeviceOrientation(90, 0, -90, 90), want, 'landscape θ=90 euler');
  // The image's up is device +x, which points Up; device −x would point Down.
  const qCW = cameraQuatFromSensorQuaternion(sensor, 90);
  const qDE = [sensor[3], sensor[0], sensor[1], sensor[2]];
  assertVecClose(
    quatRotateVector(quatMultiply(Q_ENU_TO_WORLD, qDE), [1, 0, 0]),
    quatRotateVector(qCW, CAM_UP),
    'device +x and image up coincide in the world',
  );
});

test('landscape, top to the right (θ = 270) and upside down (θ = 180), facing North', () => {
  const want = { forward: NORTH, up: UP, right: EAST };
  // Turned clockwise: device x → Down, y (top) → East, z → South.
  assertCameraPointing(
    cameraQuatFromSensorQuaternion(sensorQuatFromDeviceAxesENU(ENU_D, ENU_E, ENU_S), 270),
    want,
    'landscape θ=270',
  );
  // Upside down: device x → West, y → Down, z → South.
  assertCameraPointing(
    cameraQuatFromSensorQuaternion(sensorQuatFromDeviceAxesENU(ENU_W, ENU_D, ENU_S), 180),
    want,
    'upside down θ=180',
  );
  // window.orientation's −90 means the same as 270.
  assertCameraPointing(
    cameraQuatFromSensorQuaternion(sensorQuatFromDeviceAxesENU(ENU_D, ENU_E, ENU_S), -90),
    want,
    'landscape θ=−90',
  );
});

// ---------------------------------------------------------------------------------------------
// Consistency

test('device quaternion from Euler angles matches the spec rotation matrix (200 random)', () => {
  const rand = rng(1);
  for (let i = 0; i < 200; i++) {
    const alpha = rand() * 360;
    const beta = rand() * 360 - 180;
    const gamma = rand() * 180 - 90;
    const q = deviceQuatFromEuler(alpha, beta, gamma);
    const m = specRotationMatrix(alpha, beta, gamma);
    for (const v of [[1, 0, 0], [0, 1, 0], [0, 0, 1], [0.3, -0.5, 0.8]]) {
      assertVecClose(quatRotateVector(q, v), matVec(m, v), `#${i} (${alpha}, ${beta}, ${gamma}) v=${v}`);
    }
  }
});

test('Euler path and sensor-quaternion path agree (200 random × each screen angle)', () => {
  const rand = rng(2);
  for (let i = 0; i < 200; i++) {
    const alpha = rand() * 360;
    const beta = rand() * 360 - 180;
    const gamma = rand() * 180 - 90;
    const sensor = specSensorQuaternion(alpha, beta, gamma);
    for (const theta of SCREEN_ANGLES) {
      const a = cameraQuatFromDeviceOrientation(alpha, beta, gamma, theta);
      const b = cameraQuatFromSensorQuaternion(sensor, theta);
      const what = `#${i} (${alpha}, ${beta}, ${gamma}) θ=${theta}`;
      assertUnitCanonical(a, `${what} euler`);
      assertUnitCanonical(b, `${what} sensor`);
      assertSameRotation(a, b, what);
    }
  }
});

test('sensorQuaternionFromCameraQuat inverts cameraQuatFromSensorQuaternion (all screen angles)', () => {
  const rand = rng(3);
  for (let i = 0; i < 200; i++) {
    const [w, x, y, z] = randomUnitQuatWXYZ(rand);
    const sensor = [x, y, z, w];
    const camera = randomUnitQuatWXYZ(rand);
    for (const theta of SCREEN_ANGLES) {
      const what = `#${i} θ=${theta}`;
      const cam = cameraQuatFromSensorQuaternion(sensor, theta);
      const back = sensorQuaternionFromCameraQuat(cam, theta);
      assertUnitCanonical(back, `${what} back`);
      assert.ok(back[3] >= 0, `${what}: sensor w ≥ 0`);
      assertSameRotation(back, sensor, `${what} sensor → camera → sensor`);

      const s = sensorQuaternionFromCameraQuat(camera, theta);
      assertSameRotation(cameraQuatFromSensorQuaternion(s, theta), camera, `${what} camera → sensor → camera`);
    }
  }
});

test('outputs are unit quaternions with w ≥ 0, also for unnormalised sensor input', () => {
  const rand = rng(4);
  for (let i = 0; i < 200; i++) {
    const q = randomUnitQuatWXYZ(rand);
    const scale = 0.5 + rand() * 3;
    const sensor = [q[1] * scale, q[2] * scale, q[3] * scale, q[0] * scale];
    for (const theta of SCREEN_ANGLES) {
      const a = cameraQuatFromSensorQuaternion(sensor, theta);
      const b = cameraQuatFromDeviceOrientation(rand() * 360, rand() * 360 - 180, rand() * 180 - 90, theta);
      for (const [name, r] of [['sensor', a], ['euler', b]]) {
        assertUnitCanonical(r, `#${i} θ=${theta} ${name}`);
        assert.ok(r[0] >= 0, `#${i} θ=${theta} ${name}: w = ${r[0]} < 0`);
      }
    }
  }
});

test('OrientationHistory: the reading of when a frame was taken, interpolated between two', () => {
  const h = new OrientationHistory(1000);
  assertVecClose(h.at(5), [1, 0, 0, 0], 'identity before any reading');
  const a = quatFromAxisAngle([0, 1, 0], 0);
  const b = quatFromAxisAngle([0, 1, 0], 30);
  h.add(100, a);
  h.add(200, b);
  assertVecClose(h.at(150), quatFromAxisAngle([0, 1, 0], 15), 'half way: half the angle');
  assertVecClose(h.at(125), quatFromAxisAngle([0, 1, 0], 7.5), 'a quarter of the way');
  assertVecClose(h.at(250), b, 'after the newest: the newest');
  assertVecClose(h.at(50), a, 'before the oldest: the oldest');
  assertVecClose(h.at(undefined), b, 'no time: the newest');
  // A reading that arrives late goes in its place; the oldest go after keepMs.
  h.add(180, quatFromAxisAngle([0, 1, 0], 20));
  assertVecClose(h.at(190), quatFromAxisAngle([0, 1, 0], 25), 'between the late one and the newest');
  h.add(1300, a);
  assertVecClose(h.at(150), b, 'readings older than a second before the newest are gone');
  // Along the shorter arc, whatever the sign of the quaternions.
  const g = new OrientationHistory();
  g.add(0, quatFromAxisAngle([1, 0, 0], 170));
  g.add(10, quatFromAxisAngle([1, 0, 0], -170).map((v) => -v));
  assertVecClose(g.at(5), quatFromAxisAngle([1, 0, 0], 180), 'through 180 degrees, not 0');
});
