// The stream wire protocol in JavaScript: the byte layout of include/mirage/stream/protocol.h and
// src/stream/protocol.cpp (the source). Little-endian; every message is one WebSocket binary frame:
// 12-byte header (magic "MRGS", uint16 version, uint16 type, uint32 payload length), then the payload.
// Decoding checks every length against the bytes left and throws an Error of one line.
import {COLOUR_ONLY_BLOCK, ATLAS_MIN_BLOCK_LOG2, ATLAS_MAX_BLOCK_LOG2} from './atlas.js';

export const PROTOCOL_VERSION = 1;
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
  JpegTiles : 1 << 2
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
const HEADER_BYTES = 12;

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
  count(entryBytes, f) {
    const n = this.u32(f);
    if (n * entryBytes > this.left())
      throw new Error(`${f} ${n} entries need ${n * entryBytes} bytes, ${this.left()} left`);
    return n;
  }
}

function readWelcome(r) {
  const m = {};
  m.sessionId = r.u64('sessionId');
  m.sceneMin = r.vec3('sceneMin');
  m.sceneMax = r.vec3('sceneMax');
  m.atlasWidth = r.u32('atlasWidth');
  m.atlasHeight = r.u32('atlasHeight');
  m.codec = r.u8('codec');
  m.patchCount = r.u32('patchCount');
  m.maxMessageBytes = r.u32('maxMessageBytes');
  m.maxPoseRate = r.u32('maxPoseRate');
  if (m.atlasWidth === 0 || m.atlasHeight === 0 || m.atlasWidth > 16384 || m.atlasHeight > 16384)
    throw new Error(`atlas size ${m.atlasWidth}x${m.atlasHeight} not in 1..16384`);
  if (m.codec < 1 || m.codec > 3) throw new Error(`codec ${m.codec} not a codec id (1..3)`);
  return m;
}

function readPatch(r) {
  const p = {};
  p.id = r.u32('id');
  p.triangleCount = r.u8('triangleCount');
  p.alpha = r.u8('alpha');
  p.blockLog2 = r.u8('blockLog2');
  const reserved = r.u8('reserved');
  p.blockX = r.u16('blockX');
  p.blockY = r.u16('blockY');
  if (p.triangleCount < 1 || p.triangleCount > 3) throw new Error(`triangleCount ${p.triangleCount} not in 1..3`);
  if (p.alpha > 2) throw new Error(`alpha ${p.alpha} not an alpha mode (0..2)`);
  if (reserved !== 0) throw new Error(`reserved ${reserved} not 0`);
  p.colourOnly = p.blockLog2 === COLOUR_ONLY_BLOCK;
  if (!p.colourOnly && (p.blockLog2 < ATLAS_MIN_BLOCK_LOG2 || p.blockLog2 > ATLAS_MAX_BLOCK_LOG2))
    throw new Error(`blockLog2 ${p.blockLog2} not in 1..7 or 255 (colour-only)`);
  p.positions = [];
  for (let v = 0; v < p.triangleCount + 2; ++v) p.positions.push(r.vec3(`positions[${v}]`));
  return p;
}

function readFrame(r) {
  const m = {};
  m.sequence = r.u32('sequence');
  m.poseSequence = r.u32('poseSequence');
  m.serverTimeUs = r.u64('serverTimeUs');
  let n = r.count(4, 'removed count');
  m.removed = new Array(n);
  for (let i = 0; i < n; ++i) m.removed[i] = r.u32(`removed[${i}]`);
  n = r.count(48, 'updated count'); // 12 fixed bytes + at least 3 positions
  m.updated = new Array(n);
  for (let i = 0; i < n; ++i) {
    try {
      m.updated[i] = readPatch(r);
    } catch (e) {
      throw new Error(`updated[${i}].${e.message}`);
    }
  }
  n = r.count(8, 'colours count');
  m.colours = new Array(n);
  for (let i = 0; i < n; ++i) {
    const id = r.u32(`colours[${i}].id`);
    m.colours[i] = {id, rgba : [ r.u8('rgba'), r.u8('rgba'), r.u8('rgba'), r.u8('rgba') ]};
  }
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
