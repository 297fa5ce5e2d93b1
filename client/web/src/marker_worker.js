// The page's marker tracking, off its main thread: opencv.js (~11 MB, loaded by this worker
// only, so the page shows and streams before it is ready) finds the marker and its pose
// (marker.js); the page hands the result to the C++ pose filter and WorldFromMarker
// (WebClient.markerSeen). A classic worker: opencv.js is a UMD script that importScripts loads;
// marker.js, a module, comes by dynamic import.
//   in:  {type: 'marker', id, size, dictionary}     once, first
//        {type: 'frame', id, image: VideoFrame or ImageBitmap (transferred), k: {fx, fy, cx, cy}}
//   out: {type: 'ready'}                              opencv.js is initialised
//        {type: 'result', id, found, ms}              found: marker.js's detect() result
//        {type: 'error', id?, message}
let tracker = null;
let canvas = null;
let ctx = null;
let gray = null;
let planes = null;
// Limited-range luma codes (16-235) to full range.
const kFullRange = Uint8Array.from({ length: 256 }, (_, v) => Math.max(0, Math.min(255, Math.round(((v - 16) * 255) / 219))));

function fail(message, id) {
  self.postMessage({ type: 'error', id, message: String(message) });
}

// opencv.js, initialised, as {cv}: the emscripten Module is a thenable that hands itself back,
// so a promise resolved with the Module itself never settles.
function openCv() {
  return new Promise((resolve, reject) => {
    try {
      importScripts('opencv.js');
    } catch (e) {
      reject(new Error(`opencv.js did not load: ${e.message || e}`));
      return;
    }
    const cv = self.cv;
    if (!cv) {
      reject(new Error('opencv.js defined no cv'));
    } else if (cv.Mat) {
      resolve({ cv });
    } else {
      cv.onRuntimeInitialized = () => resolve({ cv });
      cv.onAbort = (why) => reject(new Error(`opencv.js failed: ${why}`));
    }
  });
}

// The frame's luma: a VideoFrame's own luma plane where it has one (no colour conversion), else
// drawn and weighted as OpenCV's RGB2GRAY and the native tracker's cvtColor (BT.601).
async function lumaOf(image) {
  const width = image.displayWidth || image.width;
  const height = image.displayHeight || image.height;
  if (!gray || gray.length !== width * height) gray = new Uint8Array(width * height);
  const isVideoFrame = typeof VideoFrame === 'function' && image instanceof VideoFrame;
  if (isVideoFrame && ['NV12', 'I420', 'I420A'].includes(image.format)) {
    const size = image.allocationSize();
    if (!planes || planes.length < size) planes = new Uint8Array(size);
    const [{ offset, stride }] = await image.copyTo(planes);
    const map = image.colorSpace && image.colorSpace.fullRange ? null : kFullRange;
    for (let y = 0; y < height; ++y) {
      const row = planes.subarray(offset + y * stride, offset + y * stride + width);
      if (map) for (let x = 0; x < width; ++x) gray[y * width + x] = map[row[x]];
      else gray.set(row, y * width);
    }
    return { gray, width, height };
  }
  if (!canvas || canvas.width !== width || canvas.height !== height) {
    canvas = new OffscreenCanvas(width, height);
    ctx = canvas.getContext('2d', { alpha: false, willReadFrequently: true });
  }
  ctx.drawImage(image, 0, 0);
  const rgba = ctx.getImageData(0, 0, width, height).data;
  for (let i = 0, p = 0; i < gray.length; ++i, p += 4)
    gray[i] = (rgba[p] * 4899 + rgba[p + 1] * 9617 + rgba[p + 2] * 1868 + 8192) >> 14;
  return { gray, width, height };
}

async function track({ id, image, k }) {
  const t0 = performance.now();
  try {
    const { gray: luma, width, height } = await lumaOf(image);
    const found = tracker.detect(luma, width, height, k);
    self.postMessage({ type: 'result', id, found, ms: performance.now() - t0 });
  } catch (e) {
    fail(`tracking: ${e.message || e}`, id);
  } finally {
    image.close();
  }
}

self.onmessage = async ({ data }) => {
  if (data.type === 'marker') {
    try {
      const [{ cv }, { createMarkerTracker }] = await Promise.all([openCv(), import('./marker.js')]);
      tracker = createMarkerTracker(cv, { id: data.id, size: data.size, dictionary: data.dictionary });
      self.postMessage({ type: 'ready' });
    } catch (e) {
      fail(e.message || e);
    }
  } else if (data.type === 'frame') {
    if (tracker) {
      track(data);
    } else {  // the page waits for 'ready'; a frame before it is a mistake
      data.image.close();
      fail('a frame before the tracker was ready', data.id);
    }
  }
};
