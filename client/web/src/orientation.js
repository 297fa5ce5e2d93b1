/**
 * @file Browser orientation sensors → arlight protocol camera orientation.
 *
 * Plain ES module, no dependencies. Quaternions in this module are `[w, x, y, z]` arrays unless a
 * name says otherwise; the Generic Sensor API's `[x, y, z, w]` order appears only at the boundary
 * (`cameraQuatFromSensorQuaternion` / `sensorQuaternionFromCameraQuat`).
 *
 * ## Frames
 *
 * - **Camera (C)** — protocol/RECORDING.md, common/CONVENTIONS.md: x right, y up, looking down −z
 *   (OpenGL-style), of the image *as the page receives it from getUserMedia*. Browsers deliver
 *   video frames upright relative to the current screen orientation.
 * - **World (W)** — right-handed, +Y up (gravity-aligned). Heading is arbitrary in the protocol;
 *   this conversion fixes it as **+X = East, +Y = Up, −Z = North** (+Z = South).
 *   Right-handed: E × U = −N, i.e. X × Y = Z.
 * - **Earth (E)** — W3C DeviceOrientation / Generic Sensor: ENU, X East, Y North, Z Up.
 * - **Device (D)** — W3C: x to the right of the screen in the device's natural (portrait)
 *   orientation, y towards the top of the screen, z out of the screen towards the user.
 *
 * ## Conversion
 *
 * The protocol orientation is `q_CW` (rotates camera coordinates into world coordinates):
 *
 *     q_CW = q_EW ⊗ q_DE ⊗ q_CD
 *
 * - `q_DE` — device → ENU. From `AbsoluteOrientationSensor.quaternion` directly (reordered from
 *   `[x, y, z, w]`), or from `deviceorientation` as `R = Rz(alpha) · Rx(beta) · Ry(gamma)`.
 * - `q_EW` — ENU → world: East ↦ +X, North ↦ −Z, Up ↦ +Y. That is the rotation by **−90° about
 *   X**: `Rx(−90°) = [[1,0,0],[0,0,1],[0,−1,0]]` sends (0,1,0) ↦ (0,0,−1) and (0,0,1) ↦ (0,1,0).
 * - `q_CD` — camera → device, from the screen orientation angle θ = `screen.orientation.angle`:
 *
 *       q_CD = rotation about device z by **−θ**   (R_CD = Rz(−θ))
 *
 * ### Derivation of the screen-angle rule
 *
 * The rear camera looks out of the back of the device, along device −z, for every θ; only the
 * in-plane axes of the delivered image depend on θ.
 *
 * θ = 0 (natural portrait): image right = device +x, image up = device +y, so C = D.
 *
 * The Screen Orientation spec defines `angle` as how far the user has turned the device
 * *counter-clockwise* from its natural orientation (the content compensates by rotating the same
 * amount clockwise); e.g. turning the phone to landscape with its top to the LEFT gives θ = 90,
 * top to the right gives θ = 270 (Android's Display.getRotation() has the same meaning).
 *
 * Landscape, top of the phone to the left (θ = 90). Seen by the user facing the screen, the
 * device was turned 90° counter-clockwise, so its axes turned with it:
 *   device +x (was "right") now points UP, device +y (was "up", the top) now points LEFT.
 * The browser keeps the page and the video upright, so
 *   image up    = physical up    = **device +x**
 *   image right = physical right = **device −y**
 *   image z     = x × y = (0,−1,0) × (1,0,0) = (0,0,1) = device +z (rear camera still on −z).
 * Columns of R_CD are the camera axes in device coordinates:
 *   R_CD = [[0, 1, 0], [−1, 0, 0], [0, 0, 1]] = Rz(−90°).
 * (The mapping image right = device +y, image up = device −x belongs to θ = 270, top to the
 * right: Rz(−270°) = Rz(+90°) = [[0,−1,0],[1,0,0],[0,0,1]].)
 *
 * In general the device turned by +θ about its own z (counter-clockwise seen from the user, who
 * looks along −z), and the image is the physical upright view, so image axes = device axes turned
 * back by −θ about z: **R_CD = Rz(−θ)**, `q_CD = [cos(θ/2), 0, 0, −sin(θ/2)]`.
 *
 * Summary: `q_CW = Rx(−90°) ⊗ q_DE ⊗ Rz(−θ)`, and its inverse
 * `q_DE = Rx(+90°) ⊗ q_CW ⊗ Rz(+θ)`.
 *
 * Heading: on iOS Safari, `deviceorientation`'s alpha is relative to an arbitrary reference
 * heading (and `webkitCompassHeading` gives a compass heading separately). The protocol only
 * needs a heading that is consistent within a recording, so alpha is used as is.
 */

const DEG = Math.PI / 180;

/**
 * Cosine and sine of an angle in degrees; exact for multiples of 90° so that screen-angle
 * rotations do not pick up 6e-17 noise.
 * @param {number} deg
 * @returns {[number, number]} [cos, sin]
 */
function cosSinDeg(deg) {
  const r = ((deg % 360) + 360) % 360;
  if (r === 0) return [1, 0];
  if (r === 90) return [0, 1];
  if (r === 180) return [-1, 0];
  if (r === 270) return [0, -1];
  return [Math.cos(deg * DEG), Math.sin(deg * DEG)];
}

/**
 * Hamilton product `a ⊗ b` of `[w, x, y, z]` quaternions (apply b first, then a).
 * @param {number[]} a [w, x, y, z]
 * @param {number[]} b [w, x, y, z]
 * @returns {number[]} [w, x, y, z]
 */
export function quatMultiply(a, b) {
  const [aw, ax, ay, az] = a;
  const [bw, bx, by, bz] = b;
  return [
    aw * bw - ax * bx - ay * by - az * bz,
    aw * bx + ax * bw + ay * bz - az * by,
    aw * by - ax * bz + ay * bw + az * bx,
    aw * bz + ax * by - ay * bx + az * bw,
  ];
}

/**
 * Conjugate (the inverse for a unit quaternion).
 * @param {number[]} q [w, x, y, z]
 * @returns {number[]} [w, −x, −y, −z]
 */
export function quatConjugate(q) {
  return [q[0], -q[1], -q[2], -q[3]];
}

/**
 * Scales to unit length and picks the canonical sign: w > 0, or, when w is exactly 0, the first
 * non-zero of x, y, z positive.
 * @param {number[]} q [w, x, y, z]
 * @returns {number[]} unit [w, x, y, z]
 * @throws {RangeError} for a zero or non-finite quaternion
 */
export function quatNormalize(q) {
  const n = Math.hypot(q[0], q[1], q[2], q[3]);
  if (!(n > 0) || !Number.isFinite(n)) {
    throw new RangeError(`cannot normalise quaternion [${q.join(', ')}]`);
  }
  let s = 1 / n;
  const lead = q[0] !== 0 ? q[0] : q[1] !== 0 ? q[1] : q[2] !== 0 ? q[2] : q[3];
  if (lead < 0) s = -s;
  // `+ 0` turns −0 into +0 so that results compare cleanly.
  return [q[0] * s + 0, q[1] * s + 0, q[2] * s + 0, q[3] * s + 0];
}

/**
 * Rotates a 3-vector by a unit quaternion: `q ⊗ (0, v) ⊗ q*`.
 * @param {number[]} q unit [w, x, y, z]
 * @param {number[]} v [x, y, z]
 * @returns {number[]} [x, y, z]
 */
export function quatRotateVector(q, v) {
  const [w, x, y, z] = q;
  const [vx, vy, vz] = v;
  // t = 2 (q.xyz × v); v' = v + w t + q.xyz × t
  const tx = 2 * (y * vz - z * vy);
  const ty = 2 * (z * vx - x * vz);
  const tz = 2 * (x * vy - y * vx);
  return [
    vx + w * tx + (y * tz - z * ty),
    vy + w * ty + (z * tx - x * tz),
    vz + w * tz + (x * ty - y * tx),
  ];
}

/**
 * Unit quaternion for a rotation by `deg` degrees about a unit axis (right-hand rule).
 * @param {number[]} axis unit [x, y, z]
 * @param {number} deg
 * @returns {number[]} [w, x, y, z]
 */
export function quatFromAxisAngle(axis, deg) {
  const [c, s] = cosSinDeg(deg / 2);
  return [c, axis[0] * s, axis[1] * s, axis[2] * s];
}

/**
 * Normalises a screen orientation angle to [0, 360). Accepts `window.orientation`'s −90 (older
 * iOS Safari without `screen.orientation`), which becomes 270.
 * @param {number} deg
 * @returns {number}
 * @throws {RangeError} for a non-finite angle
 */
export function normalizeScreenAngle(deg) {
  if (typeof deg !== 'number' || !Number.isFinite(deg)) {
    throw new RangeError(`screen angle must be a finite number of degrees, got ${deg}`);
  }
  return (((deg % 360) + 360) % 360) + 0;
}

/** ENU earth → protocol world (+X East, +Y Up, −Z North): −90° about X. */
export const Q_ENU_TO_WORLD = Object.freeze(quatFromAxisAngle([1, 0, 0], -90));

/**
 * Camera → device rotation for a screen orientation angle: Rz(−θ) (see the file comment).
 * @param {number} screenAngleDeg `screen.orientation.angle` (0, 90, 180, 270)
 * @returns {number[]} [w, x, y, z]
 */
export function cameraToDeviceQuat(screenAngleDeg) {
  return quatFromAxisAngle([0, 0, 1], -normalizeScreenAngle(screenAngleDeg));
}

/**
 * Device → ENU earth rotation from `deviceorientation` angles: Rz(alpha) · Rx(beta) · Ry(gamma).
 * @param {number} alpha degrees about earth Z (up)
 * @param {number} beta degrees about the rotated X
 * @param {number} gamma degrees about the twice-rotated Y
 * @returns {number[]} unit [w, x, y, z]
 */
export function deviceQuatFromEuler(alpha, beta, gamma) {
  for (const [name, v] of [['alpha', alpha], ['beta', beta], ['gamma', gamma]]) {
    if (typeof v !== 'number' || !Number.isFinite(v)) {
      throw new RangeError(`${name} must be a finite number of degrees, got ${v}`);
    }
  }
  const qz = quatFromAxisAngle([0, 0, 1], alpha);
  const qx = quatFromAxisAngle([1, 0, 0], beta);
  const qy = quatFromAxisAngle([0, 1, 0], gamma);
  return quatNormalize(quatMultiply(quatMultiply(qz, qx), qy));
}

/**
 * Protocol camera orientation from a device→ENU quaternion.
 * @param {number[]} qDE device → ENU, [w, x, y, z]
 * @param {number} screenAngleDeg
 * @returns {number[]} unit [w, x, y, z], w ≥ 0, camera → world
 */
function cameraQuatFromDeviceQuat(qDE, screenAngleDeg) {
  const qCD = cameraToDeviceQuat(screenAngleDeg);
  return quatNormalize(quatMultiply(quatMultiply(Q_ENU_TO_WORLD, qDE), qCD));
}

/**
 * Protocol camera orientation from `AbsoluteOrientationSensor.quaternion`.
 * @param {ArrayLike<number>} sensorXYZW `[x, y, z, w]`, device → ENU earth
 * @param {number} screenAngleDeg `screen.orientation.angle` (0, 90, 180, 270)
 * @returns {number[]} unit `[w, x, y, z]`, w ≥ 0, rotating camera coordinates into the world
 *   frame (+X East, +Y Up, −Z North)
 */
export function cameraQuatFromSensorQuaternion(sensorXYZW, screenAngleDeg) {
  if (!sensorXYZW || sensorXYZW.length !== 4) {
    throw new RangeError('sensor quaternion must have 4 components [x, y, z, w]');
  }
  const [x, y, z, w] = Array.from(sensorXYZW, Number);
  const qDE = quatNormalize([w, x, y, z]);
  return cameraQuatFromDeviceQuat(qDE, screenAngleDeg);
}

/**
 * Protocol camera orientation from `deviceorientation` event angles (for browsers without
 * AbsoluteOrientationSensor, e.g. iOS Safari). alpha's zero is whatever the browser uses
 * (North when `event.absolute`, otherwise an arbitrary but steady reference).
 * @param {number} alpha degrees
 * @param {number} beta degrees
 * @param {number} gamma degrees
 * @param {number} screenAngleDeg `screen.orientation.angle` (0, 90, 180, 270)
 * @returns {number[]} unit `[w, x, y, z]`, w ≥ 0, camera → world
 */
export function cameraQuatFromDeviceOrientation(alpha, beta, gamma, screenAngleDeg) {
  return cameraQuatFromDeviceQuat(deviceQuatFromEuler(alpha, beta, gamma), screenAngleDeg);
}

/**
 * The exact inverse of `cameraQuatFromSensorQuaternion`: the AbsoluteOrientationSensor reading
 * that produces a given camera orientation (used to drive Chrome DevTools' sensor override from
 * a recorded camera trajectory). `q_DE = Rx(+90°) ⊗ q_CW ⊗ Rz(+θ)`.
 * @param {number[]} cameraWXYZ camera → world, [w, x, y, z]
 * @param {number} screenAngleDeg `screen.orientation.angle` (0, 90, 180, 270)
 * @returns {number[]} unit `[x, y, z, w]`, w ≥ 0, device → ENU earth
 */
export function sensorQuaternionFromCameraQuat(cameraWXYZ, screenAngleDeg) {
  if (!cameraWXYZ || cameraWXYZ.length !== 4) {
    throw new RangeError('camera quaternion must have 4 components [w, x, y, z]');
  }
  const qCW = quatNormalize(Array.from(cameraWXYZ, Number));
  const qDC = quatConjugate(cameraToDeviceQuat(screenAngleDeg));
  const qWE = quatConjugate(Q_ENU_TO_WORLD);
  const [w, x, y, z] = quatNormalize(quatMultiply(quatMultiply(qWE, qCW), qDC));
  return [x, y, z, w];
}

/**
 * Spherical interpolation between unit quaternions a (s = 0) and b (s = 1), along the shorter
 * arc.
 * @param {number[]} a unit [w, x, y, z]
 * @param {number[]} b unit [w, x, y, z]
 * @param {number} s in [0, 1]
 * @returns {number[]} unit [w, x, y, z]
 */
export function quatSlerp(a, b, s) {
  let dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
  const sign = dot < 0 ? -1 : 1;
  dot *= sign;
  if (dot > 0.9995) return quatNormalize(a.map((v, i) => v + s * (sign * b[i] - v)));
  const theta = Math.acos(dot);
  const wa = Math.sin((1 - s) * theta) / Math.sin(theta);
  const wb = (sign * Math.sin(s * theta)) / Math.sin(theta);
  return quatNormalize(a.map((v, i) => wa * v + wb * b[i]));
}

/**
 * The recent orientation readings with their times, and the orientation at a given time: a
 * camera frame reaches the page tens of milliseconds after it was taken, while the sensors'
 * newest reading is of now, so a frame is paired with the reading of when it was taken
 * (interpolated between the two around it; the newest for a time after it, the oldest kept for
 * one before).
 */
export class OrientationHistory {
  /** @param {number} keepMs how far back readings are kept */
  constructor(keepMs = 1000) {
    this.keepMs = keepMs;
    this.readings = [];  // {ms, q}, oldest first
  }

  /** A reading taken at `ms` (performance.now()'s clock): q, camera -> world [w, x, y, z]. */
  add(ms, q) {
    const r = this.readings;
    if (!Number.isFinite(ms)) ms = r.length ? r[r.length - 1].ms : 0;
    // A reading older than the newest (clocks of two sources) goes in its place.
    let at = r.length;
    while (at > 0 && r[at - 1].ms > ms) --at;
    r.splice(at, 0, { ms, q });
    while (r.length > 2 && r[0].ms < r[r.length - 1].ms - this.keepMs) r.shift();
  }

  /** The newest reading's orientation, or identity before any. */
  latest() {
    return this.readings.length ? this.readings[this.readings.length - 1].q : [1, 0, 0, 0];
  }

  /** The orientation at `ms`; the newest without a time. */
  at(ms) {
    const r = this.readings;
    if (!Number.isFinite(ms) || r.length === 0 || ms >= r[r.length - 1].ms) return this.latest();
    if (ms <= r[0].ms) return r[0].q;
    let i = r.length - 1;
    while (r[i - 1].ms > ms) --i;
    const a = r[i - 1];
    const b = r[i];
    return b.ms > a.ms ? quatSlerp(a.q, b.q, (ms - a.ms) / (b.ms - a.ms)) : b.q;
  }
}
