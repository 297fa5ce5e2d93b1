// The composite, one at a time: the camera frame into the renderer's texture (frame_upload.js),
// then the object over it (WebClient.render), the time both took told to the soft shadows'
// frame-rate control. The frame loop skips a frame while one is busy; the probe (test_hooks.js)
// waits its turn.
import { state } from './status.js';

export class Compositor {
  constructor(upload, client) {
    this.upload = upload;
    this.client = client;
    this.current = null;  // the composite on its way
  }

  get busy() {
    return this.current !== null;
  }

  /**
   * Composites `image` (a VideoFrame or ImageBitmap; null: the <video>'s current frame) at time
   * `t` (s) with orientation `q`; `measure` false keeps it out of the upload's trials.
   */
  async composite(t, q, image = null, measure = true) {
    while (this.current) await this.current;
    this.current = (async () => {
      state.grabMs = await this.upload.upload(image, { measure });
      state.renderMs = this.client.render(t, q[0], q[1], q[2], q[3]);
      this.client.frameTook(state.grabMs + state.renderMs);  // the soft shadow's frame-rate control
    })();
    try {
      await this.current;
    } finally {
      this.current = null;
    }
  }
}
