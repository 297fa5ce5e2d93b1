// Where the simulator's truth puts the camera and the object in a marker room (arlight-sim
// --marker): shared by the page's marker tests. The object stands 1.5 marker sides tall on the
// marker, its centre 0.75 sides above it; cameras look down -z, +y up (OpenGL's convention).
import { quatConjugate, quatMultiply, quatRotateVector } from '../../client/web/src/orientation.js';

const sub = (a, b) => a.map((v, i) => v - b[i]);

/** The camera's true pose in the marker frame for frame i: {position (m), orientation [w, x, y, z]}. */
export function trueCameraInMarker(truth, i) {
  const m = truth.marker.pose;
  const c = truth.poses[i];
  const toMarker = quatConjugate(m.orientation);
  return {
    position: quatRotateVector(toMarker, sub(c.position, m.position)),
    orientation: quatMultiply(toMarker, c.orientation),
  };
}

// A point p in the camera's frame, through the pinhole k: pixels, row 0 at the top.
const project = (p, k) => [k.cx + (k.fx * p[0]) / -p[2], k.cy - (k.fy * p[1]) / -p[2]];

/**
 * Where the object's centre is in the image of a camera at `pose` (in the marker frame, as the
 * page's tracks() report it) with pinhole k.
 */
export function objectPixelOf(pose, k, markerSize) {
  const p = quatRotateVector(quatConjugate(pose.orientation), sub([0, 0, 0.75 * markerSize], pose.position));
  return project(p, k);
}

/**
 * Where the truth puts the object's centre in frame i's image for pinhole k, and its distance
 * from the camera (m).
 */
export function trueObjectPixel(truth, i, k, markerSize) {
  const m = truth.marker.pose;
  const c = truth.poses[i];
  const centre = quatRotateVector(m.orientation, [0, 0, 0.75 * markerSize]).map((v, a) => v + m.position[a]);
  const p = quatRotateVector(quatConjugate(c.orientation), sub(centre, c.position));
  return { pixel: project(p, k), distance: Math.hypot(...p) };
}
