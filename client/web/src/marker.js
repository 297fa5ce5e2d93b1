// The ArUco marker's pose in a camera frame, with opencv.js (`@techstark/opencv-js`, pinned in
// package-lock.json): cv.aruco_ArucoDetector finds the marker's corners, cv.solvePnP with
// SOLVEPNP_IPPE_SQUARE (the planar-square solution) gives its pose. The same steps as the native
// client's client/track (cv::aruco + IPPE_SQUARE), for the page's tracking worker.
//
// Frames: the result is the marker's pose in the protocol's camera frame (x right, y up, looking
// down -z; common/CONVENTIONS.md), i.e. camera_from_marker; OpenCV's camera frame (x right, y
// down, z forward) differs by a rotation of 180 degrees about x. The marker's frame is cv::aruco's
// (origin at its centre, x right and y up in the marker image, z out of the marker), as the
// simulator's truth (protocol/RECORDING.md).

/**
 * @param {object} cv the initialised opencv.js module
 * @param {{dictionary?: string, id: number, size: number}} marker the marker to look for; size
 *   is the side of its black square in metres
 */
export function createMarkerTracker(cv, { dictionary = 'DICT_4X4_50', id, size }) {
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
     * @returns {{corners: number[], rotation: number[], translation: number[]} | null}
     *   corners: 8 pixel coordinates (cv::aruco order); rotation: [w, x, y, z] and translation
     *   (metres) of the marker in the protocol's camera frame; null when the marker is not seen
     */
    detect(gray, width, height, k) {
      const image = cv.matFromArray(height, width, cv.CV_8UC1, gray);
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
        const ok = cv.solvePnP(objectPoints, imagePoints, camera, dist, rvec, tvec, false,
          cv.SOLVEPNP_IPPE_SQUARE);
        imagePoints.delete();
        if (!ok) return null;
        return {
          corners: pixels,
          ...fromOpenCv(Array.from(rvec.data64F), Array.from(tvec.data64F)),
        };
      } finally {
        for (const m of [image, corners, ids, rejected, camera, dist, rvec, tvec]) m.delete();
      }
    },
    delete() {
      for (const m of [detector, refine, params, dict, objectPoints]) m.delete();
    },
  };
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
