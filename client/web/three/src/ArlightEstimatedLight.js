// ArlightEstimatedLight: arlight's light in a three.js scene, in the shape of three.js's
// XREstimatedLight (examples/jsm/webxr/XREstimatedLight.js) — a Group holding `lightProbe` (SH-9)
// and `directionalLight` (the room's primary light), with `environment` (a prefiltered GGX cube
// chain) and the events `estimationstart` / `estimationend` (and `update`, with the frame
// `frameSequence` of the capturing device that each estimate reflects) — fed by arlightd: it watches a
// session another device captures (protocol/PROTOCOL.md item 1, "Watching a session") through
// arlight's own WebAssembly light core (arlight_light.js: the protocol codec and the lighting
// state, client/web/src/light_client.cpp), not a second decoder here.
//
// The environment is arlight's GGX chain as three samples it, not re-filtered: three's PMREM
// texture is a cube render target whose mip level L holds GGX at perceptual roughness
// 1 - sqrt(1 - L / maxLod) and its shaders sample roughness r at lod maxLod * r * (2 - r)
// (PMREMGenerator.lodToRoughness, roughnessToMip) — arlightd's chain mapping exactly (Filament's;
// PROTOCOL.md item 7). Each level is uploaded as is; its last level (r = 1, the cosine-weighted
// mean) is what three reads as irradiance / pi. `filter: 'pmrem'` instead gives three the chain's
// mirror level and lets its PMREMGenerator filter it (for comparison: bench/RESULTS.md, issue 35).
// A new chain cross-fades into `environment` (one texture object for the whole session), and the
// SH and the primary light fade with it, so nothing flickers when a set arrives.
//
//   const light = new ArlightEstimatedLight(renderer, { session, device, token });
//   scene.add(light);
//   light.addEventListener('estimationstart', () => { scene.environment = light.environment; });
import {
  DirectionalLight,
  GLSL3,
  Group,
  HalfFloatType,
  LightProbe,
  LinearMipmapLinearFilter,
  LinearSRGBColorSpace,
  Mesh,
  OrthographicCamera,
  PlaneGeometry,
  PMREMGenerator,
  RawShaderMaterial,
  Scene,
  WebGLCubeRenderTarget,
} from 'three';

const kFadeSeconds = 0.2;
const kReconnectMs = 1000;
const kPingMs = 60000;  // well inside arlightd's idle timeout (300 s by default)
// Refusals that another attempt would get again.
const kFinalErrors = ['Unauthorized', 'SessionNotFound', 'BadMessage', 'Unsupported'];
const kMaxRedirects = 2;  // Moved answers followed in a row

// A cube render target three uses as a PMREM texture as it is: `levels` mip levels from `face`.
function chainTarget(face, levels) {
  const target = new WebGLCubeRenderTarget(face, {
    minFilter: LinearMipmapLinearFilter, generateMipmaps: false, type: HalfFloatType,
    colorSpace: LinearSRGBColorSpace, depthBuffer: false,
  });
  for (let level = 0; level < levels; ++level)
    target.texture.mipmaps.push({ width: face >> level, height: face >> level });
  target.texture.isPMREMTexture = true;
  return target;
}

/**
 * arlight's GGX chain — levels from the mirror down, each half the face before, each given as
 * {face, texels}: half-float RGBA, faces +X, -X, +Y, -Y, +Z, -Z one after another, rows as
 * common/CONVENTIONS.md lays them out (specular.ktx2's levels, or the light core's) — as a
 * texture three.js samples as it is (a PMREM cube render target; its `texture` goes to
 * scene.environment or material.envMap). Dispose of the target when done.
 */
export function chainToPmrem(renderer, levels) {
  const chain = chainTarget(levels[0].face, levels.length);
  renderer.initRenderTarget(chain);
  const gl = renderer.getContext();
  gl.bindTexture(gl.TEXTURE_CUBE_MAP, renderer.properties.get(chain.texture).__webglTexture);
  gl.pixelStorei(gl.UNPACK_FLIP_Y_WEBGL, false);
  gl.pixelStorei(gl.UNPACK_PREMULTIPLY_ALPHA_WEBGL, false);
  gl.pixelStorei(gl.UNPACK_ALIGNMENT, 8);
  levels.forEach(({ face, texels }, level) => {
    const per = face * face * 4;
    for (let f = 0; f < 6; ++f)
      gl.texSubImage2D(gl.TEXTURE_CUBE_MAP_POSITIVE_X + f, level, 0, 0, face, face, gl.RGBA,
        gl.HALF_FLOAT, texels.subarray(f * per, (f + 1) * per));
  });
  renderer.resetState();  // three's view of the GL state after ours
  return chain;
}

// Renders mix(from, to, t) into one face and level of a chain target: each texel samples both
// chains in its own direction (GL's cube table; the faces are +X, -X, +Y, -Y, +Z, -Z) at the lod
// of its level's roughness in each.
class ChainBlend {
  constructor() {
    this.material = new RawShaderMaterial({
      glslVersion: GLSL3,
      uniforms: {
        from: { value: null }, to: { value: null }, t: { value: 1 }, face: { value: 0 },
        size: { value: 1 }, fromLod: { value: 0 }, toLod: { value: 0 },
      },
      vertexShader: 'in vec3 position; void main() { gl_Position = vec4(position.xy, 0.0, 1.0); }',
      fragmentShader: `precision highp float;
        uniform samplerCube from, to; uniform float t, size, fromLod, toLod; uniform int face;
        out vec4 colour;
        void main() {
          vec2 uv = 2.0 * gl_FragCoord.xy / size - 1.0;
          vec3 d = face == 0 ? vec3(1.0, -uv.y, -uv.x) : face == 1 ? vec3(-1.0, -uv.y, uv.x)
                 : face == 2 ? vec3(uv.x, 1.0, uv.y) : face == 3 ? vec3(uv.x, -1.0, -uv.y)
                 : face == 4 ? vec3(uv.x, -uv.y, 1.0) : vec3(-uv.x, -uv.y, -1.0);
          vec4 a = t < 1.0 ? textureLod(from, d, fromLod) : vec4(0.0);
          colour = vec4(mix(a.rgb, textureLod(to, d, toLod).rgb, t), 1.0);
        }`,
      depthTest: false, depthWrite: false,
    });
    this.scene = new Scene();
    this.scene.add(new Mesh(new PlaneGeometry(2, 2), this.material));
    this.camera = new OrthographicCamera();
  }

  // out = mix(from, to, t) at every face and level; `from` may be null when t = 1.
  render(renderer, out, from, to, t) {
    const u = this.material.uniforms;
    const lodFor = (target, roughness) => {  // three's roughnessToMip in that chain
      const maxLod = target.texture.mipmaps.length - 1;
      return maxLod * roughness * (2 - roughness);
    };
    const outMax = out.texture.mipmaps.length - 1;
    const previous = renderer.getRenderTarget();
    u.from.value = from ? from.texture : to.texture;
    u.to.value = to.texture;
    u.t.value = from ? t : 1;
    for (let level = 0; level <= outMax; ++level) {
      const roughness = outMax > 0 ? 1 - Math.sqrt(1 - level / outMax) : 0;
      const size = out.width >> level;
      u.size.value = size;
      u.fromLod.value = from ? lodFor(from, roughness) : 0;
      u.toLod.value = lodFor(to, roughness);
      out.viewport.set(0, 0, size, size);
      for (let face = 0; face < 6; ++face) {
        u.face.value = face;
        renderer.setRenderTarget(out, face, level);
        renderer.render(this.scene, this.camera);
      }
    }
    out.viewport.set(0, 0, out.width, out.height);
    renderer.setRenderTarget(previous);
  }

  dispose() {
    this.material.dispose();
    this.scene.children[0].geometry.dispose();
  }
}

const blend = new ChainBlend();

/**
 * three's own filtering instead (for comparison): the chain's mirror level given to
 * `pmremGenerator.fromCubemap`, which importance-samples GGX into its own chain.
 */
export function threePmremOfMirror(renderer, chain, pmremGenerator) {
  const mirror = chainTarget(chain.width, 1);
  mirror.texture.isPMREMTexture = false;
  blend.render(renderer, mirror, null, chain, 1);
  const filtered = pmremGenerator.fromCubemap(mirror.texture);
  mirror.dispose();
  return filtered;
}

export class ArlightEstimatedLight extends Group {
  /**
   * @param {import('three').WebGLRenderer} renderer
   * @param {object} options
   * @param {string} options.session the session to watch (its id: the capturing page shows it)
   * @param {string} options.device a device id of arlightd's tokens file (the session's own, or
   *   a watch-only name)
   * @param {string} options.token its token
   * @param {string} [options.server] the WebSocket URL (default: this page's origin, /ws)
   * @param {string|URL} [options.core] the light core's script (default: arlight_light.js beside
   *   this module)
   * @param {boolean} [options.environmentEstimation] keep `environment` (default true)
   * @param {'arlight'|'pmrem'} [options.filter] the environment as arlightd filtered it (default)
   *   or the chain's mirror level filtered by three's PMREMGenerator
   * @param {number} [options.environmentFace] the face of `environment`'s level 0 (default 256)
   * @param {number} [options.fadeSeconds] how long a change cross-fades (default 0.2)
   */
  constructor(renderer, options = {}) {
    super();
    this.lightProbe = new LightProbe();
    this.lightProbe.intensity = 0;
    this.add(this.lightProbe);
    this.directionalLight = new DirectionalLight();
    this.directionalLight.intensity = 0;
    this.add(this.directionalLight);
    this.environment = null;

    this._renderer = renderer;
    this._options = {
      server: `wss://${location.host}/ws`,
      core: new URL('./arlight_light.js', import.meta.url),
      environmentEstimation: true, filter: 'arlight', environmentFace: 256,
      fadeSeconds: kFadeSeconds, ...options,
    };
    this._status = {
      connected: false, watching: false, session_id: '', updates: 0, map_sets: 0,
      frame_sequence: 0, environment_face: 0, last_error: '',
    };
    this._estimate = null;     // lightEstimate()'s
    this._lightFade = null;    // {start, from, to}: the SH and primary light's cross-fade
    this._chain = null;        // the newest chain (a PMREM texture three could use as it is)
    this._environment = null;  // the target behind `environment`: what the scene samples
    this._shown = null;        // what it showed when its cross-fade to _chain began
    this._environmentFade = null;  // when that began
    this._pmrem = null;
    this._started = false;
    this._disposed = false;
    this._refused = false;
    this._movedTo = '';  // a Moved answer's web port: where the next connection goes
    this._redirects = 0;  // Moved answers followed in a row
    this._ws = null;
    this._ticking = false;
    this._core = this._loadCore();
    this._connect();
  }

  /** What the provider has: for pages and tests. */
  status() {
    return { ...this._status };
  }

  /**
   * The newest estimate in WebXR's XRLightEstimate shape (sphericalHarmonicsCoefficients: 27
   * floats, 9 RGB triples, raw radiance in WebXR's / three's order; primaryLightDirection
   * towards the light; primaryLightIntensity its RGB illuminance), or null before the first.
   */
  lightEstimate() {
    return this._estimate;
  }

  /**
   * The newest GGX chain as arlightd sent it, one level: {face, levels, roughness, texels} with
   * texels half-float RGBA, faces +X, -X, +Y, -Y, +Z, -Z one after another (null before one).
   */
  async chainLevel(level) {
    const client = await this._core;
    if (level < 0 || level >= client.chainLevels()) return null;
    return {
      face: client.chainFace(level), levels: client.chainLevels(),
      roughness: client.chainRoughness(level), texels: client.chainLevelHalfRgba(level),
    };
  }

  dispose() {
    this._disposed = true;
    if (this._ws) this._ws.close();
    clearInterval(this._pinger);
    for (const t of [this._chain, this._environment, this._shown]) if (t) t.dispose();
    if (this._pmrem) this._pmrem.dispose();
    this.remove(this.lightProbe);
    this.remove(this.directionalLight);
    this.environment = null;
  }

  async _loadCore() {
    const url = new URL(this._options.core, location.href);
    const { default: createArlightLight } = await import(url.href);
    const core = await createArlightLight({ locateFile: (file) => new URL(file, url).href });
    return new core.LightClient();
  }

  async _connect() {
    let client;
    try {
      client = await this._core;
    } catch (e) {
      this._status.last_error = `the light core did not load: ${e.message || e}`;
      return;
    }
    if (this._disposed) return;
    // After a Moved answer, once to the arlightd that has the session (PROTOCOL.md "A fleet").
    const ws = new WebSocket(this._movedTo ? `wss://${this._movedTo}/ws` : this._options.server);
    this._movedTo = '';
    this._ws = ws;
    ws.binaryType = 'arraybuffer';
    ws.onopen = () => {
      const { device, token, session } = this._options;
      ws.send(client.hello(device || '', token || '', session || ''));
      clearInterval(this._pinger);
      this._pinger = setInterval(() => ws.readyState === WebSocket.OPEN &&
        ws.send(client.ping(Date.now())), kPingMs);
    };
    ws.onmessage = (event) => this._receive(client, new Uint8Array(event.data));
    ws.onclose = () => {
      clearInterval(this._pinger);
      this._status.connected = false;
      this._status.watching = false;
      if (this._started) {
        this._started = false;
        this.dispatchEvent({ type: 'estimationend' });
      }
      if (!this._disposed && !this._refused)
        setTimeout(() => this._connect(), this._movedTo ? 0 : kReconnectMs);
    };
  }

  _receive(client, bytes) {
    const kind = client.receive(bytes);
    this._status.updates = client.updates();
    this._status.map_sets = client.mapSets();
    if (kind === 'welcome') {
      this._redirects = 0;
      this._status.connected = true;
      this._status.watching = true;
      this._status.session_id = client.sessionId();
    } else if (kind === 'error') {
      const error = client.error();
      if (error.startsWith('Moved:') && client.movedTo() && this._redirects < kMaxRedirects) {
        this._redirects += 1;
        this._movedTo = client.movedTo();
        return;
      }
      this._status.last_error = error;
      if (kFinalErrors.some((code) => error.startsWith(`${code}:`))) this._refused = true;
    } else if (kind === 'update') {
      this._takeEstimate(client);
      this._status.frame_sequence = client.frameSequence();
      this.dispatchEvent({ type: 'update', frameSequence: this._status.frame_sequence });
    } else if (kind === 'maps') {
      // The chain gives the primary light its own estimate (light.json's): take it now.
      this._takeEstimate(client);
      if (this._options.environmentEstimation) this._takeChain(client);
    }
  }

  _takeEstimate(client) {
    const sh = client.sh9();
    if (sh.length !== 27) return;
    const primary = client.primaryLight();
    const [x, y, z] = primary.direction;
    const [r, g, b] = primary.intensity;
    this._estimate = {
      sphericalHarmonicsCoefficients: sh,
      primaryLightDirection: { x, y, z, w: 0 },
      primaryLightIntensity: { x: r, y: g, z: b, w: 1 },
    };
    // As XREstimatedLight: the colour normalised, its largest channel (at least 1) the intensity.
    const scalar = Math.max(1, r, g, b);
    this._startFade({
      sh, colour: [r / scalar, g / scalar, b / scalar], intensity: scalar, direction: [x, y, z],
    });
    if (!this._started) {
      this._started = true;
      this.dispatchEvent({ type: 'estimationstart' });
    }
  }

  _takeChain(client) {
    const levels = [];
    for (let level = 0; level < client.chainLevels(); ++level)
      levels.push({ face: client.chainFace(level), texels: client.chainLevelHalfRgba(level) });
    if (!levels.length || levels[0].face < 1) return;
    const renderer = this._renderer;
    let chain = chainToPmrem(renderer, levels);
    if (this._options.filter === 'pmrem') {
      if (!this._pmrem) this._pmrem = new PMREMGenerator(renderer);
      const filtered = threePmremOfMirror(renderer, chain, this._pmrem);
      chain.dispose();
      chain = filtered;
    }
    if (this._chain) this._chain.dispose();
    this._chain = chain;
    if (!this._environment) {  // the first: shown at once, in the texture kept from now on
      const out = this._options.environmentFace;
      this._environment = chainTarget(out, Math.max(1, Math.log2(out) - 3));  // down to 16
      this._shown = chainTarget(out, this._environment.texture.mipmaps.length);
      this.environment = this._environment.texture;
      this._status.environment_face = out;
      blend.render(renderer, this._environment, null, chain, 1);
      return;
    }
    // Fade from what `environment` shows now (mid-fade too) to the new chain.
    blend.render(renderer, this._shown, null, this._environment, 1);
    this._environmentFade = performance.now();
    this._startTicking();
  }

  // A cross-fade of the SH and the primary light to `light`, from what they show now.
  _startFade(light) {
    this._lightFade = { start: performance.now(), from: this._shownLight(), to: light };
    this._startTicking();
  }

  _startTicking() {
    if (this._ticking) return;
    this._ticking = true;
    requestAnimationFrame(() => this._tick());
  }

  _shownLight() {
    if (!(this.lightProbe.intensity > 0)) return null;  // nothing shown yet: no fade
    const d = this.directionalLight;
    const sh = new Float32Array(27);
    this.lightProbe.sh.toArray(sh);
    return {
      sh, colour: [d.color.r, d.color.g, d.color.b], intensity: d.intensity,
      direction: [d.position.x, d.position.y, d.position.z],
    };
  }

  _tick() {
    if (this._disposed) return;
    const seconds = Math.max(this._options.fadeSeconds, 1e-6);
    const progress = (start) => Math.min(1, (performance.now() - start) / 1000 / seconds);
    let going = false;
    if (this._lightFade) {
      const { from, to, start } = this._lightFade;
      const t = from ? progress(start) : 1;
      const mix = (a, b) => (from ? a.map((v, i) => v + (b[i] - v) * t) : b);
      this.lightProbe.sh.fromArray(mix(from && from.sh, to.sh));
      this.lightProbe.intensity = 1;
      const c = mix(from && from.colour, to.colour);
      this.directionalLight.color.setRGB(c[0], c[1], c[2]);
      this.directionalLight.intensity = mix(from && [from.intensity], [to.intensity])[0];
      const [x, y, z] = mix(from && from.direction, to.direction);
      this.directionalLight.position.set(x, y, z);
      if (t < 1) going = true;
      else this._lightFade = null;
    }
    if (this._environmentFade !== null) {
      const t = progress(this._environmentFade);
      blend.render(this._renderer, this._environment, this._shown, this._chain, t);
      if (t < 1) going = true;
      else this._environmentFade = null;
    }
    this._ticking = going;
    if (going) requestAnimationFrame(() => this._tick());
  }
}
