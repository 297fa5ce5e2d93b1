// Encodes camera frames as JPEG off the page's main thread. Chrome encodes canvas blobs in idle
// time; the page's main thread has none while it composites every camera frame, so there a
// 640x480 frame took 1.2-2 s to encode (bench/RESULTS.md) against ~5 ms here.
//   in:  {id, bitmap: ImageBitmap (transferred), quality}
//   out: {id, jpeg: ArrayBuffer (transferred)} or {id, error}
let canvas = null;
let ctx = null;

self.onmessage = async (event) => {
  const { id, bitmap, quality } = event.data;
  try {
    if (!canvas || canvas.width !== bitmap.width || canvas.height !== bitmap.height) {
      canvas = new OffscreenCanvas(bitmap.width, bitmap.height);
      ctx = canvas.getContext('2d', { alpha: false });
    }
    ctx.drawImage(bitmap, 0, 0);
    bitmap.close();
    const blob = await canvas.convertToBlob({ type: 'image/jpeg', quality });
    const jpeg = await blob.arrayBuffer();
    self.postMessage({ id, jpeg }, [jpeg]);
  } catch (e) {
    self.postMessage({ id, error: String(e && e.message ? e.message : e) });
  }
};
