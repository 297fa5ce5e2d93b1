// The camera's frame into the renderer's camera texture (WebClient.cameraTexture, in the
// module's WebGL2 context), the way that is fastest on this browser:
//  - 'video': texSubImage2D straight from the <video>. A phone's GPU takes it without a copy.
//  - 'yuv': the frame's planes copied out with WebCodecs (VideoFrame.copyTo: NV12 or I420, no
//    colour conversion) and uploaded as two or three small textures that the module converts to
//    RGB on the GPU (yuv_frame.hpp) with the frame's own matrix and range. On SwiftShader (a
//    CPU) this is ~5 ms a 640x480 frame against ~30 ms for the <video> (bench/RESULTS.md).
//  - 'auto' (the default): both on alternate frames at the start, then the faster by median.
//  - 'canvas', 'imagedata': through a 2D canvas (measurements only).
const kTrialFrames = 6;  // per method, for 'auto'

export class FrameUpload {
  /**
   * @param {object} module the WebAssembly module (its GL object)
   * @param {object} client the WebClient
   * @param {HTMLVideoElement} video
   * @param {object} grabber camera.js's FrameGrabber for the same video
   * @param {{width: number, height: number, mode?: string}} options
   */
  constructor(module, client, video, grabber, { width, height, mode = 'auto' }) {
    if (!['auto', 'video', 'yuv', 'canvas', 'imagedata'].includes(mode))
      throw new RangeError(`upload=${mode}: auto, video, yuv, canvas or imagedata`);
    this.module = module;
    this.client = client;
    this.video = video;
    this.grabber = grabber;
    this.width = width;
    this.height = height;
    this.gl = module.GL.currentContext.GLctx;
    this.cameraTexture = module.GL.textures[client.cameraTexture()];
    this.buffer = null;
    // 'auto' tries; the trials' milliseconds per method.
    this.mode = mode === 'auto' ? (typeof VideoFrame === 'function' ? 'trial' : 'video') : mode;
    this.trials = { video: [], yuv: [] };
  }

  /** The method in use: 'video', 'yuv', ... or 'trial' while 'auto' still measures. */
  get method() {
    return this.mode;
  }

  /**
   * Uploads the video's current frame, or `image` (a VideoFrame or ImageBitmap of it); `measure`
   * false keeps the call out of 'auto''s trials (the page's probe). Milliseconds it took.
   */
  async upload(image = null, { measure = true } = {}) {
    let method = this.mode;
    if (method === 'trial') method = this.trials.video.length <= this.trials.yuv.length ? 'video' : 'yuv';
    const t0 = performance.now();
    const isVideoFrame = image && typeof VideoFrame === 'function' && image instanceof VideoFrame;
    if (method === 'yuv' && image && !isVideoFrame) method = 'video';  // a bitmap: as it is
    if (method === 'yuv') {
      try {
        await this.uploadYuv(image);
      } catch {
        // A frame the conversion cannot take (another pixel format): the <video> from now on.
        this.mode = 'video';
        this.uploadSource(image || this.video);
        method = 'video';
      }
    } else if (method === 'canvas') {
      this.grabber.draw();
      this.uploadSource(this.grabber.canvas);
    } else if (method === 'imagedata') {
      this.grabber.draw();
      this.uploadSource(this.grabber.ctx.getImageData(0, 0, this.width, this.height));
    } else {
      this.uploadSource(image || this.video);
    }
    const ms = performance.now() - t0;
    if (this.mode === 'trial' && measure) this.decide(method, ms);
    return ms;
  }

  decide(method, ms) {
    this.trials[method].push(ms);
    const { video, yuv } = this.trials;
    if (video.length < kTrialFrames || yuv.length < kTrialFrames) return;
    const median = (v) => [...v].sort((a, b) => a - b)[v.length >> 1];
    this.mode = median(yuv) < median(video) ? 'yuv' : 'video';
  }

  uploadSource(source) {
    const { gl } = this;
    gl.bindTexture(gl.TEXTURE_2D, this.cameraTexture);
    gl.pixelStorei(gl.UNPACK_FLIP_Y_WEBGL, false);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
    gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, this.width, this.height, gl.RGB, gl.UNSIGNED_BYTE, source);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 4);
    gl.bindTexture(gl.TEXTURE_2D, null);
  }

  async uploadYuv(image = null) {
    const { gl, width, height } = this;
    const frame = image || new VideoFrame(this.video);
    try {
      const layout = frame.format;
      if (layout !== 'NV12' && layout !== 'I420') throw new Error(`frame format ${layout}`);
      if (frame.displayWidth !== width || frame.displayHeight !== height)
        throw new Error(`frame ${frame.displayWidth}x${frame.displayHeight}, not ${width}x${height}`);
      const size = frame.allocationSize();
      if (!this.buffer || this.buffer.length < size) this.buffer = new Uint8Array(size);
      const planes = await frame.copyTo(this.buffer);
      // NV12: Y, then Cb Cr interleaved; I420: Y, Cb, Cr. Chroma at half size.
      const formats = layout === 'NV12' ? [[gl.RED, 1], [gl.RG, 2]] : [[gl.RED, 1], [gl.RED, 1], [gl.RED, 1]];
      gl.pixelStorei(gl.UNPACK_FLIP_Y_WEBGL, false);
      gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
      formats.forEach(([format, bytes], i) => {
        const w = i ? width / 2 : width;
        const h = i ? height / 2 : height;
        gl.bindTexture(gl.TEXTURE_2D, this.module.GL.textures[this.client.yuvPlaneTexture(layout, i)]);
        gl.pixelStorei(gl.UNPACK_ROW_LENGTH, planes[i].stride / bytes);
        gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, w, h, format, gl.UNSIGNED_BYTE, this.buffer, planes[i].offset);
      });
      gl.pixelStorei(gl.UNPACK_ROW_LENGTH, 0);
      gl.pixelStorei(gl.UNPACK_ALIGNMENT, 4);
      gl.bindTexture(gl.TEXTURE_2D, null);
      // Browsers leave the matrix out for some cameras; BT.601, limited range, is what cameras
      // and Chromium assume for standard definition then.
      const cs = frame.colorSpace || {};
      this.client.convertYuv(layout, cs.matrix || 'smpte170m', cs.fullRange === true);
    } finally {
      if (frame !== image) frame.close();
    }
  }
}
