// The camera's orientation from the phone's motion sensors: the Generic Sensor API's
// AbsoluteOrientationSensor where the browser has one, else deviceorientation events; orientation.js
// converts either to the protocol's camera -> world quaternion. state.orientation says which.
import { cameraQuatFromDeviceOrientation, cameraQuatFromSensorQuaternion, OrientationHistory } from './orientation.js';
import { showError, state } from './status.js';

/** iOS asks for motion sensors on a tap: asked here (on Start), a refusal shown. */
export async function askMotionPermission() {
  if (typeof DeviceOrientationEvent !== 'undefined' &&
      typeof DeviceOrientationEvent.requestPermission === 'function') {
    try {
      await DeviceOrientationEvent.requestPermission();
    } catch (e) {
      showError(`motion sensors: ${e.name || e}`);
    }
  }
}

/**
 * Starts the sensors; returns the orientation's getter (camera -> world, [w, x, y, z]): at a
 * time (ms, performance.now()'s clock: when a camera frame was taken), or the newest.
 */
export function startOrientation() {
  const history = new OrientationHistory();
  const screenAngle = () => (screen.orientation ? screen.orientation.angle : window.orientation || 0);
  if ('AbsoluteOrientationSensor' in window) {
    try {
      const sensor = new AbsoluteOrientationSensor({ frequency: 60, referenceFrame: 'device' });
      sensor.addEventListener('reading', () => {
        // Sensor.timestamp: when the reading was taken, on performance.now()'s clock.
        const ms = Number.isFinite(sensor.timestamp) ? sensor.timestamp : performance.now();
        history.add(ms, cameraQuatFromSensorQuaternion(sensor.quaternion, screenAngle()));
        state.orientation = 'absolute-orientation-sensor';
      });
      sensor.addEventListener('error', (e) => showError(`orientation sensor: ${e.error.name}`));
      sensor.start();
    } catch (e) {
      showError(`orientation sensor: ${e.name || e}`);
    }
  }
  window.addEventListener('deviceorientation', (e) => {
    if (state.orientation === 'absolute-orientation-sensor' || e.alpha === null) return;
    history.add(e.timeStamp, cameraQuatFromDeviceOrientation(e.alpha, e.beta, e.gamma, screenAngle()));
    state.orientation = 'deviceorientation';
  });
  return (ms) => history.at(ms);
}
