// The page's side of the JPEG encoder: frames handed to jpeg_worker.js (which says why a worker)
// and their JPEG bytes back, each encode() a promise of its own.
export class JpegEncoder {
  constructor() {
    this.worker = new Worker('jpeg_worker.js');
    this.pending = new Map();  // id -> {resolve, reject}
    this.next = 0;
    this.worker.onmessage = ({ data }) => {
      const p = this.pending.get(data.id);
      this.pending.delete(data.id);
      if (!p) return;
      if (data.error) p.reject(new Error(data.error));
      else p.resolve(new Uint8Array(data.jpeg));
    };
  }

  /**
   * `image` (a VideoFrame or ImageBitmap, transferred) -> a promise of its JPEG's bytes, the
   * image `reduction` (1, 2, 4, 8) times smaller each side.
   */
  encode(image, quality, reduction = 1) {
    const id = ++this.next;
    return new Promise((resolve, reject) => {
      this.pending.set(id, { resolve, reject });
      this.worker.postMessage({ id, image, quality, reduction }, [image]);
    });
  }
}
