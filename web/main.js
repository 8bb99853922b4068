// The browser thin client (docs/stream.md, "The browser client"): connects to the page's own host by WebSocket, says
// Hello, keeps the patches each Frame sends, decodes the atlas into a texture and draws at the
// display's rate from the latest atlas. ?path=<camera JSON>&record=1 replays a fixed camera path:
// each camera is drawn once its frame has arrived and decoded, its pixels go to
// window.mirageFrames[i] (a PNG data URL) and document.title says "frame i/N", then "done N".
import {
  encodeHello,
  encodePose,
  decodeMessage,
  MessageType,
  Capability,
  AtlasCodec,
  CloseCodeNames,
  inflatePatchSection,
  zstdPatchesSupported
} from './protocol.js';
import {AtlasTexture, h264Supported} from './atlas_codec.js';
import {PatchSet} from './patches.js';
import {PatchRenderer} from './renderer.js';
import {
  FlyControls,
  loadCameraPath,
  protocolCamera,
  viewProjection,
  lookAt,
  withClipPlanes,
  add,
  sub,
  scale,
  normalize
} from './camera.js';
import {startXr, xrAvailable} from './xr.js';

const params = new URLSearchParams(location.search);
const fragment = new URLSearchParams(location.hash.slice(1));
const param = (name) => fragment.get(name) ?? params.get(name);

const canvas = document.getElementById('view');
const status = document.getElementById('status');
const record = param('record') === '1';
window.mirageFrames = [];

function say(text) {
  status.textContent = text;
  if (!record) return;
  console.log(text);
}
function fail(text) {
  say(`error: ${text}`);
  document.title = `error: ${text}`;
}

// A fixed size in path mode (identical images run to run), else the window's.
function sizeCanvas() {
  const width = Number(param('width')) || (record ? 640 : Math.round(canvas.clientWidth * devicePixelRatio));
  const height = Number(param('height')) || (record ? 480 : Math.round(canvas.clientHeight * devicePixelRatio));
  canvas.width = width;
  canvas.height = height;
  if (record) {
    canvas.style.width = `${width}px`;
    canvas.style.height = `${height}px`;
  }
}

// The automatic 3/4 view of camera.h (a fixed direction from above-front-right, the bounds framed).
function autoCamera(min, max, aspect) {
  const center = scale(add(min, max), 0.5);
  const radius = Math.max(0.5 * Math.hypot(...sub(max, min)), 1e-3);
  const direction = normalize([ 1, 0.8, 1.4 ]);
  const fov = 60;
  const fit = radius / Math.sin(((Math.min(fov, fov * aspect) * Math.PI) / 180) / 2);
  return {eye : add(center, scale(direction, fit)), target : center, up : [ 0, 1, 0 ], fov, znear : 0, zfar : 0};
}

async function main() {
  sizeCanvas();
  const gl = canvas.getContext('webgl2', {antialias : false, preserveDrawingBuffer : record, xrCompatible : true});
  if (!gl) return fail('WebGL2 is not available');
  const renderer = new PatchRenderer(gl);
  const patches = new PatchSet();
  const path = param('path') ? await loadCameraPath(param('path')).catch((e) => fail(e.message)) : null;
  if (param('path') && !path) return;

  let capabilities = Capability.JpegTiles;
  if (param('codec') !== 'jpeg' && (await h264Supported())) capabilities |= Capability.H264;
  if (zstdPatchesSupported()) capabilities |= Capability.ZstdPatches;
  const scheme = location.protocol === 'https:' ? 'wss:' : 'ws:';
  const socket = new WebSocket(param('ws') || `${scheme}//${location.host}/`);
  socket.binaryType = 'arraybuffer';

  let welcome = null, atlas = null, camera = null, bounds = null, controls = null;
  let sequence = 0, pathIndex = 0, answeredPose = 0;
  const pending = new Map(); // pose sequence -> path index
  let decodeChain = Promise.resolve();

  function sendPose(c) {
    const wire = protocolCamera(withClipPlanes(c, bounds));
    sequence += 1;
    socket.send(encodePose({
      sequence,
      clientTimeUs : Math.round(performance.now() * 1000),
      camera : wire,
      predicted : wire,
      viewportWidth : canvas.width,
      viewportHeight : canvas.height
    }));
    return sequence;
  }

  function draw(c) {
    const clipped = withClipPlanes(c, bounds);
    renderer.draw(patches, atlas, viewProjection(clipped, canvas.width / canvas.height), clipped.eye,
                  [ 0, 0, canvas.width, canvas.height ], true, lookAt(clipped.eye, clipped.target, clipped.up));
  }

  function requestPathCamera() {
    if (pathIndex >= path.length) {
      document.title = `done ${path.length}`;
      say(`done: ${path.length} frames`);
      return;
    }
    pending.set(sendPose(path[pathIndex]), pathIndex);
  }

  // Frames apply strictly in order: each waits for the one before it to be decoded.
  async function onFrame(frame) {
    await inflatePatchSection(frame);
    patches.apply(frame);
    for (const p of patches.particles) // the clip planes take in every particle (as StreamView's)
      for (let k = 0; k < 3; ++k) {
        bounds.min[k] = Math.min(bounds.min[k], p.position[k] - p.size);
        bounds.max[k] = Math.max(bounds.max[k], p.position[k] + p.size);
      }
    if (frame.atlas.codec === AtlasCodec.JpegTiles)
      await atlas.applyJpegTiles(frame.atlas.bytes);
    else if (frame.atlas.codec === AtlasCodec.H264)
      await atlas.applyH264(frame.atlas.bytes, frame.sequence);
    else if (frame.atlas.codec !== AtlasCodec.None)
      throw new Error(`atlas codec ${frame.atlas.codec} is not decoded here`);
    answeredPose = Math.max(answeredPose, frame.poseSequence);
    if (path && pending.has(frame.poseSequence)) {
      const index = pending.get(frame.poseSequence);
      pending.delete(frame.poseSequence);
      draw(path[index]);
      window.mirageFrames[index] = canvas.toDataURL('image/png');
      document.title = `frame ${index + 1}/${path.length}`;
      pathIndex = index + 1;
      requestPathCamera();
    }
  }

  socket.onopen = () => {
    say('connected');
    socket.send(encodeHello({
      token : param('token') || '',
      capabilities,
      viewportWidth : canvas.width,
      viewportHeight : canvas.height,
      stereo : false
    }));
  };
  socket.onclose = (e) => {
    if (!document.title.startsWith('done')) fail(`connection closed (${e.code} ${e.reason})`);
  };
  socket.onerror = () => fail('WebSocket error');
  socket.onmessage = (event) => {
    let m;
    try {
      m = decodeMessage(event.data);
    } catch (e) {
      socket.close();
      return fail(`server: ${e.message}`);
    }
    if (m.type === MessageType.Welcome) {
      welcome = m;
      bounds = {min : [...m.sceneMin ], max : [...m.sceneMax ]}; // copies: particles grow them
      patches.setWelcome(m);
      atlas = new AtlasTexture(gl, m.atlasWidth, m.atlasHeight);
      say(`session ${m.sessionId}: ${m.patchCount} patches, atlas ${m.atlasWidth}x${m.atlasHeight}, codec ${m.codec}`);
      if (path) return requestPathCamera();
      camera = autoCamera(m.sceneMin, m.sceneMax, canvas.width / canvas.height);
      controls = new FlyControls(window, camera);
      controls.speed = Math.max(0.1, Math.hypot(...sub(m.sceneMax, m.sceneMin)) * 0.25);
      interactive();
    } else if (m.type === MessageType.Frame) {
      if (!welcome) return fail('server: Frame before Welcome');
      decodeChain = decodeChain.then(() => onFrame(m)).catch((e) => fail(`frame ${m.sequence}: ${e.message}`));
    } else if (m.type === MessageType.Close) {
      fail(`server closed: ${CloseCodeNames[m.code] ?? m.code}: ${m.reason}`);
    }
  };

  // Interactive: draw every display frame; one pose in flight at a time (the next goes out when
  // the frame for the last arrived), so the server is never asked for more than the client shows.
  // The predicted pose is the current one (no motion extrapolation yet).
  function interactive() {
    let last = performance.now(), lastPoseTime = 0;
    const tick = (now) => {
      controls.update((now - last) / 1000);
      last = now;
      // A pose the server skipped (rate limit, overload) must not stall the client: resend after 250 ms.
      if (socket.readyState === WebSocket.OPEN && (answeredPose >= sequence || now - lastPoseTime > 250)) {
        sendPose(camera);
        lastPoseTime = now;
      }
      draw(camera);
      requestAnimationFrame(tick);
    };
    requestAnimationFrame(tick);
    if (xrAvailable()) {
      const button = document.getElementById('xr');
      button.hidden = false;
      button.onclick = () =>
          startXr(gl, renderer, patches, () => atlas, (c) => sendPose(c), () => bounds).catch((e) => say(e.message));
    }
  }
}

window.addEventListener('resize', () => {
  if (!record) sizeCanvas();
});
main().catch((e) => fail(e.message));
