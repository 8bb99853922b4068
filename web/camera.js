// Cameras as `mirage render` has them (include/mirage/render/camera.h): eye, target, up (y-up),
// vertical fov in degrees, right-handed look-at, clip planes from the scene bounds when not given
// (withClipPlanes). WebGL clip space is y-up with depth in [-1, 1], so the projection is the
// standard OpenGL one; the image matches the native reverse-Z Vulkan one (both put +y up on screen).
export function sub(a, b) { return [ a[0] - b[0], a[1] - b[1], a[2] - b[2] ]; }
export function add(a, b) { return [ a[0] + b[0], a[1] + b[1], a[2] + b[2] ]; }
export function scale(a, s) { return [ a[0] * s, a[1] * s, a[2] * s ]; }
export function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
export function cross(a, b) {
  return [ a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0] ];
}
export function normalize(a) {
  const l = Math.hypot(a[0], a[1], a[2]) || 1;
  return scale(a, 1 / l);
}

// Column-major 4x4 (WebGL's uniformMatrix4fv layout), like glm::lookAtRH.
export function lookAt(eye, target, up) {
  const f = normalize(sub(target, eye));
  const s = normalize(cross(f, up));
  const u = cross(s, f);
  return new Float32Array(
      [ s[0], u[0], -f[0], 0, s[1], u[1], -f[1], 0, s[2], u[2], -f[2], 0, -dot(s, eye), -dot(u, eye), dot(f, eye), 1 ]);
}

export function perspective(fovYDegrees, aspect, znear, zfar) {
  const t = 1 / Math.tan((fovYDegrees * Math.PI) / 360);
  return new Float32Array([
    t / aspect, 0, 0, 0, 0, t, 0, 0, 0, 0, (zfar + znear) / (znear - zfar), -1, 0, 0,
    (2 * zfar * znear) / (znear - zfar), 0
  ]);
}

export function multiply(a, b) {
  const out = new Float32Array(16);
  for (let c = 0; c < 4; ++c)
    for (let r = 0; r < 4; ++r) {
      let v = 0;
      for (let k = 0; k < 4; ++k) v += a[k * 4 + r] * b[c * 4 + k];
      out[c * 4 + r] = v;
    }
  return out;
}

// camera.h withClipPlanes: near/far bracket the bounds' sphere as seen from the eye.
export function withClipPlanes(camera, bounds) {
  if (camera.znear > 0 && camera.zfar > camera.znear) return camera;
  const center = bounds ? scale(add(bounds.min, bounds.max), 0.5) : [ 0, 0, 0 ];
  const radius = bounds ? Math.max(0.5 * Math.hypot(...sub(bounds.max, bounds.min)), 1e-6) : 1;
  const dist = Math.hypot(...sub(camera.eye, center));
  const zfar = dist + radius * 1.01;
  // Standard depth has less precision than the native reverse-Z: a larger minimum near plane.
  const znear = Math.max(dist - radius * 1.01, zfar * 1e-4);
  return {...camera, znear : camera.znear > 0 ? camera.znear : znear, zfar : Math.max(zfar, znear * 2)};
}

export function viewProjection(camera, aspect) {
  return multiply(perspective(camera.fov, aspect, camera.znear, camera.zfar),
                  lookAt(camera.eye, camera.target, camera.up));
}

// One camera of a path file, as loadCameraPath reads it: a --camera string
// "eye=x,y,z,target=x,y,z,fov=60[,up=x,y,z]" or {"eye": [..], "target": [..], "up": [..], "fov": deg,
// "znear": n, "zfar": f}.
export function parseCamera(entry, index) {
  const camera = {eye : null, target : null, up : [ 0, 1, 0 ], fov : 60, znear : 0, zfar : 0};
  if (typeof entry === 'string') {
    const parts = entry.split(',');
    for (let i = 0; i < parts.length;) {
      const [key, first] = parts[i].split('=');
      if (first === undefined) throw new Error(`camera ${index}: '${parts[i]}' is not key=value`);
      if (key === 'fov' || key === 'znear' || key === 'zfar') {
        camera[key] = Number(first);
        i += 1;
      } else {
        camera[key] = [ Number(first), Number(parts[i + 1]), Number(parts[i + 2]) ];
        i += 3;
      }
    }
  } else if (entry && typeof entry === 'object') {
    Object.assign(camera, entry);
  }
  for (const key of ['eye', 'target', 'up'])
    if (!Array.isArray(camera[key]) || camera[key].length !== 3 || !camera[key].every(Number.isFinite))
      throw new Error(`camera ${index}: '${key}' must be three numbers`);
  if (!(camera.fov > 0 && camera.fov < 180)) throw new Error(`camera ${index}: fov ${camera.fov} not in (0, 180)`);
  return camera;
}

export async function loadCameraPath(url) {
  const response = await fetch(url);
  if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
  let json = await response.json();
  if (json && !Array.isArray(json) && Array.isArray(json.cameras)) json = json.cameras;
  if (!Array.isArray(json) || json.length === 0) throw new Error(`${url}: expected a non-empty array of cameras`);
  return json.map(parseCamera);
}

// The protocol's camera (fovY in radians) of a page camera.
export function protocolCamera(c) {
  return {eye : c.eye, target : c.target, up : c.up, fovY : (c.fov * Math.PI) / 180};
}

// Free flight: WASD moves along the view, Q/E down/up, dragging turns (yaw about +y, pitch).
export class FlyControls {
  constructor(element, camera) {
    this.camera = camera;
    this.keys = new Set();
    this.speed = 1;
    element.addEventListener('keydown', (e) => this.keys.add(e.key.toLowerCase()));
    element.addEventListener('keyup', (e) => this.keys.delete(e.key.toLowerCase()));
    let drag = null;
    element.addEventListener('pointerdown', (e) => { drag = [ e.clientX, e.clientY ]; });
    element.addEventListener('pointerup', () => { drag = null; });
    element.addEventListener('pointermove', (e) => {
      if (!drag) return;
      this.turn((e.clientX - drag[0]) * -0.005, (e.clientY - drag[1]) * -0.005);
      drag = [ e.clientX, e.clientY ];
    });
  }
  turn(yaw, pitch) {
    const c = this.camera;
    let f = sub(c.target, c.eye);
    const dist = Math.hypot(...f);
    f = normalize(f);
    const cy = Math.cos(yaw), sy = Math.sin(yaw);
    f = [ f[0] * cy + f[2] * sy, f[1], -f[0] * sy + f[2] * cy ];
    const elevation = Math.max(-1.5, Math.min(1.5, Math.asin(Math.max(-1, Math.min(1, f[1]))) + pitch));
    const h = Math.hypot(f[0], f[2]) || 1;
    f = [ (f[0] / h) * Math.cos(elevation), Math.sin(elevation), (f[2] / h) * Math.cos(elevation) ];
    c.target = add(c.eye, scale(f, dist));
  }
  update(seconds) {
    const c = this.camera;
    const f = normalize(sub(c.target, c.eye));
    const r = normalize(cross(f, c.up));
    let move = [ 0, 0, 0 ];
    const k = this.keys;
    if (k.has('w')) move = add(move, f);
    if (k.has('s')) move = sub(move, f);
    if (k.has('d')) move = add(move, r);
    if (k.has('a')) move = sub(move, r);
    if (k.has('e')) move = add(move, c.up);
    if (k.has('q')) move = sub(move, c.up);
    if (move[0] || move[1] || move[2]) {
      const step = scale(normalize(move), this.speed * seconds);
      c.eye = add(c.eye, step);
      c.target = add(c.target, step);
      return true;
    }
    return false;
  }
}
