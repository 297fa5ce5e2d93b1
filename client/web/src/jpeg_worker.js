// Encodes camera frames as JPEG off the page's main thread. Chrome encodes canvas blobs in idle
// time; the page's main thread has none while it composites every camera frame, so there a
// 640x480 frame took 1.2-2 s to encode (bench/RESULTS.md) against ~5 ms here.
//   in:  {id, image: VideoFrame or ImageBitmap (transferred), quality, reduction: 1, 2, 4 or 8
//        (the daemon's frame advice: drawn that many times smaller, smoothing at high quality)}
//   out: {id, jpeg: ArrayBuffer (transferred)} or {id, error}
let canvas = null;
let ctx = null;

self.onmessage = async (event) => {
  const { id, image, quality, reduction = 1 } = event.data;
  try {
    const width = Math.floor((image.displayWidth || image.width) / reduction);
    const height = Math.floor((image.displayHeight || image.height) / reduction);
    if (!canvas || canvas.width !== width || canvas.height !== height) {
      canvas = new OffscreenCanvas(width, height);
      // A CPU canvas (willReadFrequently): encoding reads it back whole, and a GPU one would
      // queue every frame through the GPU process, which also draws the page.
      ctx = canvas.getContext('2d', { alpha: false, willReadFrequently: true });
      ctx.imageSmoothingQuality = 'high';
    }
    ctx.drawImage(image, 0, 0, width, height);
    const blob = await canvas.convertToBlob({ type: 'image/jpeg', quality });
    const jpeg = await blob.arrayBuffer();
    self.postMessage({ id, jpeg }, [jpeg]);
  } catch (e) {
    self.postMessage({ id, error: String(e && e.message ? e.message : e) });
  } finally {
    image.close();
  }
};
