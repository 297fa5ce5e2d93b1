// The connection to arlightd: a WebSocket to the page's own origin (/ws) carrying the protocol
// the module encodes and decodes (WebClient.hello, .frame, .receive, ...). Each time it opens:
// Hello (resuming state.sessionId), the intrinsics, a map request; after a drop, the same again a
// second later, unless arlightd refused the device, the protocol or the session (then for good);
// after a link gone quiet (no answer for 1.5 s), at once.
// Frames go one at a time, encoded as JPEG off the main thread (jpeg_encoder.js), and only while
// little waits in the socket: a frame offered meanwhile is skipped, and a newer one goes instead.
// The client core keeps the frames no checkpoint holds yet; after a resume the ones the session
// lacks go again before any newer frame (no frame lost in a fail-over, PROTOCOL.md).
import { JpegEncoder } from './jpeg_encoder.js';
import { showError, state } from './status.js';

// Sending: at most this much may wait in the WebSocket before a newer frame replaces the next.
const kMaxBuffered = 256 * 1024;
const kReconnectMs = 1000;
// A link gone quiet (issue 36 §3, PROTOCOL.md item 5): a frame unanswered and nothing received
// for this long, or a connection not open this long after it was asked for, is given up and a
// new one opened at once; the browser's own TCP would back off for seconds after a blackout.
const kStallMs = 1500;
const kOpenTimeoutMs = 1500;
const kLatenciesKept = 2000;
// A watched or joined session on another arlightd of a fleet: at most this many Moved answers
// are followed in a row (PROTOCOL.md "A fleet"); then the page shows the refusal and retries
// from its own origin, as after any drop.
const kMaxRedirects = 2;
const kSentKept = 1000;  // state.sent

export class Connection {
  /**
   * @param {object} client the WebClient (the protocol's codec)
   * @param {{device: string, token: string, join: string}} credentials the URL's (params.js):
   *   with `join`, the page captures into that session beside its own phone (issue 49)
   */
  constructor(client, { device, token, join }) {
    this.client = client;
    this.device = device;
    this.token = token;
    this.join = join || '';
    this.ws = null;
    this.refused = false;     // for good: no reconnecting
    this.movedTo = '';        // the next connection goes there (a Moved answer's web port) ...
    this.redirects = 0;       // ... the how-manieth in a row; back to the page's origin after
    this.sequence = 0;        // the last frame's
    this.sentAt = new Map();  // frame sequence -> performance.now() when it went
    this.encoding = false;    // a frame on its way
    this.encoder = new JpegEncoder();
    this.onWelcome = () => {};    // after every Welcome (the page sends its location)
    this.onFrameSent = () => {};  // (q): a frame went with orientation q
  }

  /** Connects (and reconnects after a drop, until refused). */
  open() {
    const ws = new WebSocket(`wss://${this.movedTo || location.host}/ws`);
    this.movedTo = '';
    this.ws = ws;
    this.lastReceived = performance.now();
    this.unansweredSince = null;  // when the oldest frame no update has answered yet went
    ws.binaryType = 'arraybuffer';
    const opening = setTimeout(() => {
      if (ws.readyState === WebSocket.CONNECTING) this.abandon(ws);
    }, kOpenTimeoutMs);
    ws.onopen = () => {
      clearTimeout(opening);
      ws.send(this.client.hello(this.device, this.token, state.sessionId, this.join));
      ws.send(this.client.intrinsics());
      const maps = this.client.requestMaps();  // a contributor asks for none: it gets the session's
      if (maps) ws.send(maps);
    };
    ws.onmessage = (event) => this.receive(new Uint8Array(event.data));
    ws.onclose = () => {
      clearTimeout(opening);
      state.connected = false;
      if (!this.refused) setTimeout(() => this.open(), this.movedTo ? 0 : kReconnectMs);
    };
    if (!this.watchdog) this.watchdog = setInterval(() => this.checkStalled(), 250);
  }

  // A frame waits for its answer and nothing at all has come for kStallMs: the link is gone.
  checkStalled() {
    const { ws } = this;
    if (!ws || ws.readyState !== WebSocket.OPEN || this.unansweredSince === null) return;
    if (performance.now() - Math.max(this.lastReceived, this.unansweredSince) > kStallMs) {
      showError('arlightd has not answered for 1.5 s: reconnecting');
      this.abandon(ws);
    }
  }

  // Gives `ws` up without waiting for its closing handshake (a quiet link may never complete
  // it) and connects again at once; the Hello resumes the session.
  abandon(ws) {
    if (this.ws !== ws) return;
    ws.onopen = ws.onmessage = ws.onclose = null;
    ws.close();
    state.connected = false;
    this.open();
  }

  /** `message()`'s bytes, if the socket is open and it has any; nothing otherwise. */
  sendIfOpen(message) {
    if (!this.ws || this.ws.readyState !== WebSocket.OPEN) return;
    const bytes = message();
    if (bytes) this.ws.send(bytes);
  }

  /** The camera's intrinsics (after the field of view or the focal length changed). */
  sendIntrinsics() {
    this.sendIfOpen(() => this.client.intrinsics());
  }

  /**
   * A camera frame (the one just composited, or one waiting for its pose), with orientation `q`
   * (camera -> world, [w, x, y, z]): sent (`take` gives a transferable copy of it) unless the
   * page is not connected, a frame is still being encoded, or more than kMaxBuffered waits in
   * the socket. Returns at once.
   */
  offerFrame(q, take, mediaTime) {
    const { ws } = this;
    if (!(state.connected && !this.encoding && ws.readyState === WebSocket.OPEN &&
          ws.bufferedAmount <= kMaxBuffered)) return;
    // Frames a resumed session lacks go first (issue 36 §5): a newer one now would make the
    // daemon take them as duplicates.
    if (this.client.framesWaiting()) return this.resendKept();
    // The daemon's frame advice (PROTOCOL.md): at most the rate it needs, at the size it needs.
    const due = this.client.frameDue(performance.now() / 1000);
    if (due.send) this.sendFrame(q, take, mediaTime, due.reduction, due.quality);
  }

  // `take` is called before the first await: the frame it copies is closed once the caller is done.
  async sendFrame(q, take, mediaTime, reduction, quality) {
    this.encoding = true;
    try {
      const t0 = performance.now();
      // The frame drawn for the composite, reduced and encoded off the main thread.
      const jpeg = await this.encoder.encode(await take(), quality / 100, reduction);
      state.jpegMs = performance.now() - t0;
      const { ws } = this;
      if (!ws || ws.readyState !== WebSocket.OPEN) return;  // reconnecting meanwhile
      const seq = ++this.sequence;
      ws.send(this.client.frame(seq, performance.now() / 1000, q[0], q[1], q[2], q[3], jpeg,
                                reduction, quality));
      this.sentAt.set(seq, performance.now());
      if (this.unansweredSince === null) this.unansweredSince = performance.now();
      state.framesSent += 1;
      state.sent.push({ media_time: mediaTime, orientation: q, sequence: seq, sent_at_ms: Date.now() });
      if (state.sent.length > kSentKept) state.sent.shift();
      this.onFrameSent(q);
    } catch (e) {
      showError(`frame: ${e.message || e}`);
    } finally {
      this.encoding = false;
    }
  }

  // The kept frames a resumed session lacks, oldest first, at most the in-flight limit
  // unanswered (the client core says which and when).
  resendKept() {
    const { ws } = this;
    if (!ws || ws.readyState !== WebSocket.OPEN) return;
    for (let bytes; (bytes = this.client.resendFrame(performance.now() / 1000)) !== null;) {
      ws.send(bytes);
      if (this.unansweredSince === null) this.unansweredSince = performance.now();
    }
  }

  // One message from arlightd, into the client core (which keeps what it says: status.js reads
  // it from there); here only what the connection does about it.
  receive(bytes) {
    this.lastReceived = performance.now();
    const name = this.client.receive(bytes);
    if (name === 'Welcome') {
      state.connected = true;
      this.redirects = 0;
      const status = this.client.status();
      state.sessionId = status.session_id;
      // A resumed session (a reloaded page) has frames up to this one: a frame numbered at or
      // below it would be taken as one sent again, and not counted (PROTOCOL.md, fail-over).
      this.sequence = Math.max(this.sequence, status.session_last_sequence);
      this.onWelcome();
      // The session's own page: a token for its "capture with another phone" link.
      const join = this.client.requestJoinToken();
      if (join) this.ws.send(join);
      this.resendKept();
    } else if (name === 'LightingUpdate') {
      this.reflected(this.client.lastSequence());
      if (this.client.lastSequence() >= this.sequence) this.unansweredSince = null;
      this.resendKept();
    } else if (name === 'Error') {
      const { last_error: error, moved_to: movedTo } = this.client.status();
      // The session lives on another arlightd of the fleet: go there (not an error).
      if (error.startsWith('Moved:') && movedTo && this.redirects < kMaxRedirects) {
        this.redirects += 1;
        this.movedTo = movedTo;
        return;
      }
      showError(`refused: ${error}`);
      if (/^(Unauthorized|Unsupported|SessionNotFound)/.test(error)) this.refused = true;
    } else if (name.startsWith('refused')) {
      showError(name);
      this.ws.close();
    }
  }

  // An update reflects the frames up to `sequence`: the latency of that frame.
  reflected(sequence) {
    const t = this.sentAt.get(sequence);
    if (t === undefined) return;
    state.latencies.push(performance.now() - t);
    if (state.latencies.length > kLatenciesKept) state.latencies.shift();
    for (const k of this.sentAt.keys()) if (k <= sequence) this.sentAt.delete(k);
  }
}
