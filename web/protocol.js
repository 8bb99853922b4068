// The stream wire protocol in JavaScript: the byte layout of include/mirage/stream/protocol.h and
// src/stream/protocol.cpp, patch_section.cpp, particle_section.cpp (the source). Little-endian; every message is one
// WebSocket binary frame: 12-byte header (magic "MRGS", uint16 version, uint16 type, uint32 payload
// length), then the payload. Decoding checks every length and count against the bytes left and
// throws an Error of one line.
import {COLOUR_ONLY_BLOCK, ATLAS_MIN_BLOCK_LOG2, ATLAS_MAX_BLOCK_LOG2, atlasBlockWidth} from './atlas.js';

// 3: Frame carries a particle section (docs/stream.md, "Particle section").
export const PROTOCOL_VERSION = 3;
export const MessageType = {
  Hello : 1,
  Welcome : 2,
  Pose : 3,
  Frame : 4,
  Close : 5
};
export const Capability = {
  ZstdTiles : 1 << 0,
  H264 : 1 << 1,
  JpegTiles : 1 << 2,
  ZstdPatches : 1 << 3
};
export const AtlasCodec = {
  None : 0,
  ZstdTiles : 1,
  H264 : 2,
  JpegTiles : 3
};
export const AlphaMode = {
  Opaque : 0,
  Mask : 1,
  Blend : 2
};
export const CloseCodeNames = [
  'Normal', 'BadToken', 'Malformed', 'OutOfOrder', 'TooLarge', 'ServerFull', 'HelloTimeout', 'Overloaded', 'Unsupported'
];
export const PatchCodec = {
  Raw : 0,
  Zstd : 1
};
const HEADER_BYTES = 12;
const MAX_ATLAS_SIDE = 16384;
// Positions: grid coordinates below 2^24 (protocol.h kPositionGridBits).
export const POSITION_GRID_MAX = 2 ** 24 - 1;
// Largest decompressed patch or particle section accepted (DecodeLimits::maxPatchSectionBytes).
const MAX_PATCH_SECTION_BYTES = 64 * 1024 * 1024;
// Particle positions: 16-bit grid coordinates (protocol.h kParticleGridMax).
export const PARTICLE_GRID_MAX = 0xffff;

class Writer {
  constructor() { this.bytes = []; }
  u8(v) { this.bytes.push(v & 0xff); }
  u16(v) {
    this.u8(v);
    this.u8(v >>> 8);
  }
  u32(v) {
    for (let i = 0; i < 4; ++i) this.u8(v >>> (8 * i));
  }
  u64(v) {
    const big = BigInt(Math.max(0, Math.floor(v)));
    this.u32(Number(big & 0xffffffffn));
    this.u32(Number(big >> 32n));
  }
  f32(v) {
    const b = new DataView(new ArrayBuffer(4));
    b.setFloat32(0, v, true);
    this.u32(b.getUint32(0, true));
  }
  vec3(v) {
    this.f32(v[0]);
    this.f32(v[1]);
    this.f32(v[2]);
  }
  str16(s) {
    const b = new TextEncoder().encode(s).subarray(0, 0xffff);
    this.u16(b.length);
    for (const x of b) this.u8(x);
  }
  camera(c) {
    this.vec3(c.eye);
    this.vec3(c.target);
    this.vec3(c.up);
    this.f32(c.fovY);
  }
}

function message(type, writePayload) {
  const w = new Writer();
  for (const c of 'MRGS') w.u8(c.charCodeAt(0));
  w.u16(PROTOCOL_VERSION);
  w.u16(type);
  w.u32(0);
  writePayload(w);
  const out = new Uint8Array(w.bytes);
  new DataView(out.buffer).setUint32(8, out.length - HEADER_BYTES, true);
  return out;
}

// hello: {token, capabilities, viewportWidth, viewportHeight, stereo}
export function encodeHello(h) {
  return message(MessageType.Hello, (w) => {
    w.str16(h.token);
    w.u32(h.capabilities);
    w.u32(h.viewportWidth);
    w.u32(h.viewportHeight);
    w.u8(h.stereo ? 1 : 0);
  });
}

// pose: {sequence, clientTimeUs, camera, predicted, viewportWidth, viewportHeight}; a camera is
// {eye, target, up, fovY} with fovY in radians.
export function encodePose(p) {
  return message(MessageType.Pose, (w) => {
    w.u32(p.sequence);
    w.u64(p.clientTimeUs);
    w.camera(p.camera);
    w.camera(p.predicted);
    w.u32(p.viewportWidth);
    w.u32(p.viewportHeight);
  });
}

export function encodeClose(code, reason) {
  return message(MessageType.Close, (w) => {
    w.u16(code);
    w.str16(reason);
  });
}

class Reader {
  constructor(view, offset) {
    this.view = view;
    this.pos = offset;
  }
  left() { return this.view.byteLength - this.pos; }
  need(n, field) {
    if (n > this.left()) throw new Error(`${field}: truncated (needs ${n} bytes, ${this.left()} left)`);
  }
  u8(f) {
    this.need(1, f);
    return this.view.getUint8(this.pos++);
  }
  u16(f) {
    this.need(2, f);
    const v = this.view.getUint16(this.pos, true);
    this.pos += 2;
    return v;
  }
  u32(f) {
    this.need(4, f);
    const v = this.view.getUint32(this.pos, true);
    this.pos += 4;
    return v;
  }
  u64(f) {
    const lo = this.u32(f), hi = this.u32(f);
    return hi * 4294967296 + lo;
  }
  f32(f) {
    this.need(4, f);
    const v = this.view.getFloat32(this.pos, true);
    this.pos += 4;
    if (!Number.isFinite(v)) throw new Error(`${f}: not a finite number`);
    return v;
  }
  vec3(f) { return [ this.f32(f + '.x'), this.f32(f + '.y'), this.f32(f + '.z') ]; }
  str16(f) {
    const n = this.u16(f + ' length');
    this.need(n, f);
    const s = new TextDecoder().decode(new Uint8Array(this.view.buffer, this.view.byteOffset + this.pos, n));
    this.pos += n;
    return s;
  }
  // Unsigned LEB128, at most 32 bits, in its shortest form.
  varint(f) {
    let value = 0;
    for (let i = 0;; ++i) {
      const b = this.u8(f);
      if (i === 4 && b > 0x0f) throw new Error(`${f} varint longer than 32 bits`);
      value += (b & 0x7f) * 2 ** (7 * i);
      if (b & 0x80) continue;
      if (b === 0 && i > 0) throw new Error(`${f} varint not in its shortest form`);
      return value;
    }
  }
  checkCount(n, entryBytes, f) {
    if (n * entryBytes > this.left())
      throw new Error(`${f} ${n} entries need ${n * entryBytes} bytes, ${this.left()} left`);
    return n;
  }
  count(entryBytes, f) { return this.checkCount(this.u32(f), entryBytes, f); }
  varintCount(entryBytes, f) { return this.checkCount(this.varint(f), entryBytes, f); }
}

function readWelcome(r) {
  const m = {};
  m.sessionId = r.u64('sessionId');
  m.sceneMin = r.vec3('sceneMin');
  m.sceneMax = r.vec3('sceneMax');
  m.positionStep = r.f32('positionStep');
  m.atlasWidth = r.u32('atlasWidth');
  m.atlasHeight = r.u32('atlasHeight');
  m.codec = r.u8('codec');
  m.patchCount = r.u32('patchCount');
  m.maxMessageBytes = r.u32('maxMessageBytes');
  m.maxPoseRate = r.u32('maxPoseRate');
  if (m.atlasWidth === 0 || m.atlasHeight === 0 || m.atlasWidth > 16384 || m.atlasHeight > 16384)
    throw new Error(`atlas size ${m.atlasWidth}x${m.atlasHeight} not in 1..16384`);
  if (m.codec < 1 || m.codec > 3) throw new Error(`codec ${m.codec} not a codec id (1..3)`);
  if (!(m.positionStep > 0)) throw new Error(`positionStep ${m.positionStep} not above 0`);
  const extent = Math.max(...m.sceneMax.map((v, k) => v - m.sceneMin[k]));
  if (extent / m.positionStep > POSITION_GRID_MAX)
    throw new Error(`positionStep ${m.positionStep}: the grid does not span the scene bounds`);
  return m;
}

// Signed residuals from unsigned varints: 0, 1, 2, 3, ... -> 0, -1, 1, -2, ...
function unzigzag(z) { return z % 2 === 1 ? -(z + 1) / 2 : z / 2; }

// The grid point slot v is predicted from (patch_section.cpp): a from the previous geometry entry's
// a, b and c from a, d from b + c - a, e from b + d - c.
function predict(p, v, previousA) {
  if (v === 0) return previousA;
  if (v <= 2) return p[0];
  if (v === 3) return [ 0, 1, 2 ].map((k) => p[1][k] + p[2][k] - p[0][k]);
  return [ 0, 1, 2 ].map((k) => p[1][k] + p[3][k] - p[2][k]);
}

// One entry of the patch section: {id, triangleCount, geometry, alpha, colourOnly, blockLog2,
// blockX, blockY, positions (grid coordinates; geometry entries only)}.
function readEntry(r, nextId, state) {
  const p = {id : nextId('id')};
  const head = r.u8('head');
  if (head & 0xc0) throw new Error(`head ${head} has reserved bits set`);
  p.triangleCount = head & 3;
  if (p.triangleCount === 0) throw new Error('triangleCount 0 not in 1..3');
  p.geometry = (head & 0x10) !== 0;
  p.alpha = (head >> 2) & 3;
  if (p.alpha > 2) throw new Error(`alpha ${p.alpha} not an alpha mode (0..2)`);
  if (!p.geometry && p.alpha !== 0) throw new Error('alpha set in a block-only entry');
  p.colourOnly = (head & 0x20) !== 0;
  p.blockLog2 = COLOUR_ONLY_BLOCK;
  p.blockX = 0;
  p.blockY = 0;
  if (!p.colourOnly) {
    p.blockLog2 = r.u8('blockLog2');
    if (p.blockLog2 < ATLAS_MIN_BLOCK_LOG2 || p.blockLog2 > ATLAS_MAX_BLOCK_LOG2)
      throw new Error(`blockLog2 ${p.blockLog2} not in 1..7`);
    p.blockX = r.varint('blockX') * 2 ** p.blockLog2;
    p.blockY = r.varint('blockY') * 2 ** p.blockLog2;
    const width = atlasBlockWidth(p.triangleCount, p.blockLog2), height = 2 ** p.blockLog2;
    if (p.blockX + width > MAX_ATLAS_SIDE || p.blockY + height > MAX_ATLAS_SIDE)
      throw new Error(`blockX block at (${p.blockX}, ${p.blockY}) size ${width}x${height} outside the atlas side ${
          MAX_ATLAS_SIDE}`);
  }
  if (!p.geometry) return p;
  p.positions = [];
  for (let v = 0; v < p.triangleCount + 2; ++v) {
    const q = predict(p.positions, v, state.previousA).slice();
    for (let k = 0; k < 3; ++k) {
      const f = `positions[${v}].${'xyz'[k]}`;
      q[k] += unzigzag(r.varint(f));
      if (q[k] < 0 || q[k] > POSITION_GRID_MAX)
        throw new Error(`${f} ${q[k]} outside the grid (0..${POSITION_GRID_MAX})`);
    }
    p.positions.push(q);
  }
  state.previousA = p.positions[0];
  return p;
}

// The patch section's bytes (decompressed) into frame.removed, frame.updated, frame.colours.
export function parsePatchSection(bytes, frame) {
  const r = new Reader(new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength), 0);
  let next = 0;
  const nextId = (f) => {
    const id = next + r.varint(f);
    if (id > 0xffffffff) throw new Error(`${f} id past 2^32 - 1`);
    next = id + 1;
    return id;
  };
  let n = r.varintCount(1, 'removed count');
  frame.removed = new Array(n);
  for (let i = 0; i < n; ++i) frame.removed[i] = nextId(`removed[${i}]`);
  n = r.varintCount(2, 'updated count');
  frame.updated = new Array(n);
  next = 0;
  const state = {previousA : [ 0, 0, 0 ]};
  for (let i = 0; i < n; ++i) {
    try {
      frame.updated[i] = readEntry(r, nextId, state);
    } catch (e) {
      throw new Error(`updated[${i}].${e.message}`);
    }
  }
  n = r.varintCount(5, 'colours count');
  frame.colours = new Array(n);
  next = 0;
  for (let i = 0; i < n; ++i) {
    const id = nextId(`colours[${i}].id`);
    frame.colours[i] = {id, rgba : [ r.u8('rgba'), r.u8('rgba'), r.u8('rgba'), r.u8('rgba') ]};
  }
  if (r.left() !== 0) throw new Error(`patches ${r.left()} bytes after the colours`);
}

// An IEEE half (16 bits) as a number.
function halfToFloat(h) {
  const exponent = (h >> 10) & 0x1f, mantissa = h & 0x3ff, sign = h & 0x8000 ? -1 : 1;
  if (exponent === 0) return sign * mantissa * 2 ** -24;
  if (exponent === 31) return mantissa ? NaN : sign * Infinity;
  return sign * (1 + mantissa / 1024) * 2 ** (exponent - 15);
}

// The particle section's bytes (decompressed) into frame.looks ({id, blockLog2, blockX, blockY,
// rgba}: a 2^(log2 + 1) x 2^log2 block, level 0 and its mips; blockLog2 COLOUR_ONLY_BLOCK: rgba is
// the look's colour), frame.particleOrigin, frame.particleStep and frame.particles ({look, position
// (world), size, rotation (radians), rgba}), with particle_section.cpp's checks.
export function parseParticleSection(bytes, frame) {
  const r = new Reader(new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength), 0);
  let n = r.varintCount(4, 'looks count');
  frame.looks = new Array(n);
  let next = 0;
  for (let i = 0; i < n; ++i) {
    const f = `looks[${i}]`;
    const id = next + r.varint(`${f}.id`);
    if (id > 0xffffffff) throw new Error(`${f}.id past 2^32 - 1`);
    next = id + 1;
    const l = {id, blockLog2 : r.u8(`${f}.blockLog2`), blockX : 0, blockY : 0, rgba : [ 0, 0, 0, 0 ]};
    if (l.blockLog2 === COLOUR_ONLY_BLOCK) {
      for (let c = 0; c < 4; ++c) l.rgba[c] = r.u8(`${f}.rgba`);
    } else {
      if (l.blockLog2 < ATLAS_MIN_BLOCK_LOG2 || l.blockLog2 > ATLAS_MAX_BLOCK_LOG2)
        throw new Error(`${f}.blockLog2 ${l.blockLog2} not in 1..7 or 255 (colour-only)`);
      const side = 2 ** l.blockLog2;
      l.blockX = r.varint(`${f}.blockX`) * side;
      l.blockY = r.varint(`${f}.blockY`) * side;
      if (l.blockX + 2 * side > MAX_ATLAS_SIDE || l.blockY + side > MAX_ATLAS_SIDE) // level 0 and its mips
        throw new Error(`${f}.blockX block at (${l.blockX}, ${l.blockY}) size ${2 * side}x${
            side} outside the atlas side ${MAX_ATLAS_SIDE}`);
    }
    frame.looks[i] = l;
  }
  n = r.varintCount(15, 'particles count');
  frame.particles = new Array(n);
  frame.particleOrigin = [ 0, 0, 0 ];
  frame.particleStep = 1;
  if (n > 0) {
    frame.particleOrigin = r.vec3('particles.origin');
    frame.particleStep = r.f32('particles.step');
    if (!(frame.particleStep > 0)) throw new Error(`particles.step ${frame.particleStep} not above 0`);
    r.checkCount(n, 15, 'particles count');
  }
  const field = (what, i) => `particles[${i}].${what}`;
  for (let i = 0; i < n; ++i) frame.particles[i] = {look : r.varint(field('look', i)), position : [ 0, 0, 0 ]};
  for (let k = 0; k < 3; ++k)
    for (let i = 0; i < n; ++i)
      frame.particles[i].position[k] = // float32 arithmetic, as particlePosition (protocol.h)
          Math.fround(frame.particleOrigin[k] + Math.fround(r.u16(field('position', i)) * frame.particleStep));
  for (let i = 0; i < n; ++i) {
    const h = r.u16(field('size', i));
    if ((h & 0x8000) || (h & 0x7c00) === 0x7c00) throw new Error(`${field('size', i)} not a finite non-negative half`);
    frame.particles[i].size = halfToFloat(h);
  }
  for (let i = 0; i < n; ++i) frame.particles[i].rotation = r.u16(field('rotation', i)) * (2 * Math.PI / 65536);
  for (let i = 0; i < n; ++i) frame.particles[i].rgba = [ 0, 1, 2, 3 ].map(() => r.u8(field('rgba', i)));
  const used = new Set(frame.particles.map((p) => p.look));
  for (let i = 0; i < frame.looks.length; ++i)
    if (!used.has(frame.looks[i].id))
      throw new Error(`looks[${i}] look ${frame.looks[i].id} is used by no particle of the frame`);
  if (r.left() !== 0) throw new Error(`particles ${r.left()} bytes after the colours`);
}

// Whether this browser decompresses zstd (DecompressionStream): the page then offers
// Capability.ZstdPatches.
export function zstdPatchesSupported() {
  try {
    new DecompressionStream('zstd');
    return true;
  } catch {
    return false;
  }
}

// zstd bytes decompressed (at most MAX_PATCH_SECTION_BYTES) by DecompressionStream.
async function inflate(packed, name) {
  const reader = new Blob([ packed ]).stream().pipeThrough(new DecompressionStream('zstd')).getReader();
  const chunks = [];
  let size = 0;
  for (;;) {
    const {done, value} = await reader.read();
    if (done) break;
    size += value.length;
    if (size > MAX_PATCH_SECTION_BYTES) {
      reader.cancel();
      throw new Error(`${name}.bytes zstd content over the limit of ${MAX_PATCH_SECTION_BYTES} bytes`);
    }
    chunks.push(value);
  }
  const bytes = new Uint8Array(size);
  let at = 0;
  for (const c of chunks) {
    bytes.set(c, at);
    at += c.length;
  }
  return bytes;
}

// A Frame whose patch or particle section came compressed (frame.patchBytes, frame.particleBytes):
// decompresses and parses them into the frame. Raw sections are parsed by decodeMessage already.
export async function inflatePatchSection(frame) {
  if (frame.patchBytes) {
    const bytes = await inflate(frame.patchBytes, 'patches');
    delete frame.patchBytes;
    parsePatchSection(bytes, frame);
  }
  if (frame.particleBytes) {
    const bytes = await inflate(frame.particleBytes, 'particles');
    delete frame.particleBytes;
    parseParticleSection(bytes, frame);
  }
}

// A section's framing (codec byte, byte count, bytes): [codec, the bytes in place].
function readSection(r, name) {
  const codec = r.u8(`${name}.codec`);
  const byteCount = r.u32(`${name}.byteCount`);
  r.need(byteCount, `${name}.bytes`);
  const bytes = new Uint8Array(r.view.buffer, r.view.byteOffset + r.pos, byteCount);
  r.pos += byteCount;
  if (codec > 1) throw new Error(`${name}.codec ${codec} not 0 (raw) or 1 (zstd)`);
  return [ codec, bytes ];
}

function readFrame(r) {
  const m = {};
  m.sequence = r.u32('sequence');
  m.poseSequence = r.u32('poseSequence');
  m.serverTimeUs = r.u64('serverTimeUs');
  let section;
  [m.patchCodec, section] = readSection(r, 'patches');
  if (m.patchCodec === PatchCodec.Zstd)
    m.patchBytes = section; // inflatePatchSection
  else
    parsePatchSection(section, m);
  [m.particleCodec, section] = readSection(r, 'particles');
  if (m.particleCodec === PatchCodec.Zstd)
    m.particleBytes = section; // inflatePatchSection
  else
    parseParticleSection(section, m);
  const codec = r.u8('atlas.codec');
  const width = r.u32('atlas.width'), height = r.u32('atlas.height');
  const byteCount = r.u32('atlas.byteCount');
  if (codec > 3) throw new Error(`atlas.codec ${codec} not a codec id (0..3)`);
  r.need(byteCount, 'atlas.bytes');
  const bytes = new Uint8Array(r.view.buffer, r.view.byteOffset + r.pos, byteCount);
  r.pos += byteCount;
  m.atlas = {codec, width, height, bytes};
  return m;
}

// Decodes one message (an ArrayBuffer): {type, ...fields}. Throws an Error naming the field.
export function decodeMessage(buffer) {
  const view = new DataView(buffer);
  if (view.byteLength < HEADER_BYTES)
    throw new Error(`message of ${view.byteLength} bytes, shorter than the 12-byte header`);
  const magic = String.fromCharCode(view.getUint8(0), view.getUint8(1), view.getUint8(2), view.getUint8(3));
  if (magic !== 'MRGS') throw new Error(`not a stream message (magic '${magic}', expected 'MRGS')`);
  const version = view.getUint16(4, true), type = view.getUint16(6, true), length = view.getUint32(8, true);
  if (version !== PROTOCOL_VERSION)
    throw new Error(`protocol version ${version}, this page speaks ${PROTOCOL_VERSION}`);
  if (length !== view.byteLength - HEADER_BYTES)
    throw new Error(`payload length ${length} but ${view.byteLength - HEADER_BYTES} bytes follow the header`);
  const r = new Reader(view, HEADER_BYTES);
  const names = {2 : 'Welcome', 4 : 'Frame', 5 : 'Close'};
  if (!names[type]) throw new Error(`message type ${type} not expected from a server`);
  let m;
  try {
    if (type === MessageType.Welcome)
      m = readWelcome(r);
    else if (type === MessageType.Frame)
      m = readFrame(r);
    else
      m = {code : r.u16('code'), reason : r.str16('reason')};
  } catch (e) {
    throw new Error(`${names[type]}: ${e.message}`);
  }
  if (r.left() !== 0) throw new Error(`${names[type]}: ${r.left()} bytes after the last field`);
  m.type = type;
  return m;
}
