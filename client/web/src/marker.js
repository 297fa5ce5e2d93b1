// The ArUco marker's pose in a camera frame, with opencv.js (`@techstark/opencv-js`, pinned in
// package-lock.json): cv.aruco_ArucoDetector finds the marker's corners (sub-pixel), cv.solvePnP
// with SOLVEPNP_IPPE_SQUARE (the planar-square solution) gives its pose, cv.solvePnPRefineLM
// polishes it, and a pose whose corners reproject worse than 2 px RMS is refused. The native
// client's steps (client/track/marker_tracker.hpp) where opencv.js has them: its build lacks
// solvePnPGeneric (IPPE's second solution) and the native edge-line corner refinement is not
// ported. For the page's tracking worker (marker_worker.js).
//
// Frames: the result is the marker's pose in the protocol's camera frame (x right, y up, looking
// down -z; common/CONVENTIONS.md), i.e. camera_from_marker; OpenCV's camera frame (x right, y
// down, z forward) differs by a rotation of 180 degrees about x. The marker's frame is cv::aruco's
// (origin at its centre, x right and y up in the marker image, z out of the marker), as the
// simulator's truth (protocol/RECORDING.md).

/**
 * @param {object} cv the initialised opencv.js module
 * @param {{dictionary?: string, id: number, size: number, maxReprojectionPx?: number,
 *   srgb?: boolean}} marker the marker to look for; size is the side of its black square in
 *   metres. srgb: the frames are sRGB-encoded, and the detector sees them decoded to linear
 *   intensity, where the sub-pixel corner sits on the true edge (in code values it sits towards
 *   the white, which made the marker look larger: 1.5 cm against 1.0 cm worst position error on
 *   the simulated orbit, tests/web/marker.test.mjs), as the native edge refinement does.
 */
export function createMarkerTracker(cv, { dictionary = 'DICT_4X4_50', id, size, maxReprojectionPx = 2, srgb = true }) {
  if (!(size > 0)) throw new RangeError(`marker size ${size} m must be positive`);
  if (!Number.isInteger(id) || id < 0) throw new RangeError(`marker id ${id} must be a non-negative integer`);
  if (!(dictionary in cv)) throw new RangeError(`unknown ArUco dictionary ${dictionary}`);
  const dict = cv.getPredefinedDictionary(cv[dictionary]);
  const params = new cv.aruco_DetectorParameters();
  const refine = new cv.aruco_RefineParameters(10, 3, true);
  params.cornerRefinementMethod = cv.CORNER_REFINE_SUBPIX;
  const detector = new cv.aruco_ArucoDetector(dict, params, refine);
  const h = size / 2;
  // cv::aruco's corner order: top-left, top-right, bottom-right, bottom-left.
  const objectPoints = cv.matFromArray(4, 1, cv.CV_32FC3, [-h, h, 0, h, h, 0, h, -h, 0, -h, -h, 0]);

  return {
    /**
     * @param {Uint8Array|Uint8ClampedArray} gray width*height luminance bytes, row 0 at the top
     * @param {{fx: number, fy: number, cx: number, cy: number}} k pinhole intrinsics (pixels)
     * @returns {{corners: number[], rvec: number[], tvec: number[], reprojectionPx: number,
     *   rotation: number[], translation: number[]} | {refused: string, corners: number[]} | null}
     *   corners: 8 pixel coordinates (cv::aruco order); rvec, tvec: solvePnP's (marker -> OpenCV
     *   camera); rotation: [w, x, y, z] and translation (metres) of the marker in the protocol's
     *   camera frame; {refused, corners} when the marker was found but no pose fits its corners
     *   (a wrong focal length does that to oblique views); null when the marker is not seen
     */
    detect(gray, width, height, k) {
      const image = cv.matFromArray(height, width, cv.CV_8UC1, srgb ? linearise(gray) : gray);
      const corners = new cv.MatVector();
      const ids = new cv.Mat();
      const rejected = new cv.MatVector();
      const camera = cv.matFromArray(3, 3, cv.CV_64F, [k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1]);
      const dist = cv.Mat.zeros(1, 5, cv.CV_64F);
      const rvec = new cv.Mat();
      const tvec = new cv.Mat();
      try {
        detector.detectMarkers(image, corners, ids, rejected);
        let index = -1;
        for (let i = 0; i < ids.rows; ++i) if (ids.data32S[i] === id) index = i;
        if (index < 0) return null;
        const found = corners.get(index);
        const pixels = Array.from(found.data32F);
        found.delete();
        const imagePoints = cv.matFromArray(4, 1, cv.CV_32FC2, pixels);
        let reprojectionPx = Infinity;
        try {
          if (!cv.solvePnP(objectPoints, imagePoints, camera, dist, rvec, tvec, false,
            cv.SOLVEPNP_IPPE_SQUARE)) return null;
          cv.solvePnPRefineLM(objectPoints, imagePoints, camera, dist, rvec, tvec,
            new cv.TermCriteria(cv.TermCriteria_COUNT + cv.TermCriteria_EPS, 20, 1e-10));
          reprojectionPx = reprojectionRms(cv, objectPoints, pixels, rvec, tvec, camera, dist);
        } finally {
          imagePoints.delete();
        }
        const r = Array.from(rvec.data64F);
        const t = Array.from(tvec.data64F);
        if (!(reprojectionPx <= maxReprojectionPx) || !(t[2] > 0)) {
          return { refused: `reprojection error ${reprojectionPx.toFixed(2)} px > ${maxReprojectionPx}`, corners: pixels };
        }
        return { corners: pixels, rvec: r, tvec: t, reprojectionPx, ...fromOpenCv(r, t) };
      } finally {
        for (const m of [image, corners, ids, rejected, camera, dist, rvec, tvec]) m.delete();
      }
    },
    delete() {
      for (const m of [detector, refine, params, dict, objectPoints]) m.delete();
    },
  };
}

// sRGB code values to linear intensity, still 8-bit (the detector takes no other depth).
const kLinear = Uint8Array.from({ length: 256 }, (_, v) => {
  const c = v / 255;
  return Math.round(255 * (c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055) ** 2.4));
});
function linearise(gray) {
  const out = new Uint8Array(gray.length);
  for (let i = 0; i < gray.length; ++i) out[i] = kLinear[gray[i]];
  return out;
}

// RMS distance (pixels) between the corners and the marker's corners projected with the pose.
function reprojectionRms(cv, objectPoints, pixels, rvec, tvec, camera, dist) {
  const projected = new cv.Mat();
  try {
    cv.projectPoints(objectPoints, rvec, tvec, camera, dist, projected);
    const p = projected.depth() === cv.CV_64F ? projected.data64F : projected.data32F;
    let sum = 0;
    for (let i = 0; i < 8; ++i) sum += (p[i] - pixels[i]) ** 2;
    return Math.sqrt(sum / 4);
  } finally {
    projected.delete();
  }
}

// OpenCV's rvec/tvec (marker -> OpenCV camera) to [w, x, y, z] and a translation in the
// protocol's camera frame: flip y and z (a rotation of 180 degrees about x), F * R and F * t.
function fromOpenCv(rvec, tvec) {
  const angle = Math.hypot(rvec[0], rvec[1], rvec[2]);
  const s = angle > 0 ? Math.sin(angle / 2) / angle : 0.5;
  const q = [Math.cos(angle / 2), rvec[0] * s, rvec[1] * s, rvec[2] * s];
  // F = 180 degrees about x: (0, 1, 0, 0); F * q = [-x, w, -z, y] (Hamilton product).
  let r = [-q[1], q[0], -q[3], q[2]];
  if (r[0] < 0) r = r.map((v) => -v);
  return { rotation: r, translation: [tvec[0], -tvec[1], -tvec[2]] };
}
