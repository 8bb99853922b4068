// A server-free test of the client: a hard-coded patch set and a generated atlas go through the
// same code as a served stream (Frame bytes -> decodeMessage -> PatchSet -> JPEG tiles -> WebGL2).
// Two frames: a keyframe, then a delta that repaints one tile and removes a patch.
// ?fixture=1: decodes key.mjt then delta.mjt (written by the C++ JpegTileEncoder next to this page)
// and records the atlas texture itself, for a comparison with the encoder's source image.
// tests/stream_web/browser_test.py renders this page with scripts/browser_client.py and checks pixels;
// the scene below and the expectations there are written together (change both).
import {decodeMessage} from './protocol.js';
import {buildJpegTiles, parseJpegTiles, AtlasTexture} from './atlas_codec.js';
import {PatchSet, PatchRenderer} from './renderer.js';
import {viewProjection, withClipPlanes} from './camera.js';

const ATLAS_W = 128, ATLAS_H = 64;

function quad(x0, x1, y0, y1, z) {
  return [ [ x0, y0, z ], [ x1, y0, z ], [ x0, y1, z ], [ x1, y1, z ] ]; // a, b, c, d
}
// alpha: 0 opaque, 2 blend; blockLog2 255: colour-only.
const keyPatches = [
  {
    id : 0,
    triangleCount : 2,
    alpha : 0,
    blockLog2 : 5,
    blockX : 0,
    blockY : 0,
    positions : quad(-1.5, -0.5, -0.5, 0.5, 0)
  },
  {
    id : 1,
    triangleCount : 3,
    alpha : 0,
    blockLog2 : 5,
    blockX : 32,
    blockY : 0,
    positions : [...quad(0, 0.5, -0.5, 0.5, 0), [ 1.0, -0.5, 0 ] ]
  },
  {
    id : 2,
    triangleCount : 1,
    alpha : 0,
    blockLog2 : 255,
    blockX : 0,
    blockY : 0,
    positions : [ [ 1.1, 0.6, 0 ], [ 1.6, 0.6, 0 ], [ 1.1, 1.1, 0 ] ]
  },
  {
    id : 3,
    triangleCount : 2,
    alpha : 0,
    blockLog2 : 255,
    blockX : 0,
    blockY : 0,
    positions : quad(-1.0, 0.0, -1.0, 0.0, -0.5)
  },
  {
    id : 4,
    triangleCount : 2,
    alpha : 2,
    blockLog2 : 255,
    blockX : 0,
    blockY : 0,
    positions : quad(-1.3, -0.7, 0.1, 0.4, 0.5)
  },
  {
    id : 5,
    triangleCount : 2,
    alpha : 2,
    blockLog2 : 255,
    blockX : 0,
    blockY : 0,
    positions : quad(-1.3, -0.7, 0.1, 0.4, 0.25)
  },
];
const keyColours = [
  {id : 2, rgba : [ 255, 0, 255, 255 ]},
  {id : 3, rgba : [ 0, 255, 255, 255 ]},
  {id : 4, rgba : [ 255, 255, 255, 128 ]},
  {id : 5, rgba : [ 255, 0, 0, 128 ]},
];

// Frame message bytes, laid out as src/stream/protocol.cpp writes them.
function frameMessage(sequence, removed, updated, colours, atlasBytes) {
  const bytes = [];
  const u8 = (v) => bytes.push(v & 0xff);
  const u16 = (v) => {
    u8(v);
    u8(v >>> 8);
  };
  const u32 = (v) => {
    for (let i = 0; i < 4; ++i) u8(v >>> (8 * i));
  };
  const f32 = (v) => {
    const d = new DataView(new ArrayBuffer(4));
    d.setFloat32(0, v, true);
    u32(d.getUint32(0, true));
  };
  [77, 82, 71, 83].forEach(u8);
  u16(1);
  u16(4);
  u32(0);
  u32(sequence);
  u32(sequence);
  u32(0);
  u32(0);
  u32(removed.length);
  removed.forEach(u32);
  u32(updated.length);
  for (const p of updated) {
    u32(p.id);
    u8(p.triangleCount);
    u8(p.alpha);
    u8(p.blockLog2);
    u8(0);
    u16(p.blockX);
    u16(p.blockY);
    p.positions.forEach((v) => v.forEach(f32));
  }
  u32(colours.length);
  for (const c of colours) {
    u32(c.id);
    c.rgba.forEach(u8);
  }
  u8(3);
  u32(ATLAS_W);
  u32(ATLAS_H);
  u32(atlasBytes.length);
  const out = new Uint8Array(bytes.length + atlasBytes.length);
  out.set(bytes);
  out.set(atlasBytes, bytes.length);
  new DataView(out.buffer).setUint32(8, out.length - 12, true);
  return out.buffer;
}

// One strip: the atlas tiles `tiles` (row-major indices) side by side in one JPEG.
async function stripOf(canvas, tiles) {
  const columns = ATLAS_W / 32;
  const strip = new OffscreenCanvas(32 * tiles.length, 32);
  const g = strip.getContext('2d');
  tiles.forEach((t, k) =>
                    g.drawImage(canvas, (t % columns) * 32, Math.floor(t / columns) * 32, 32, 32, 32 * k, 0, 32, 32));
  const blob = await strip.convertToBlob({type : 'image/jpeg', quality : 0.95});
  return {tiles, jpeg : new Uint8Array(await blob.arrayBuffer())};
}

async function run() {
  const canvas = document.getElementById('view');
  const gl = canvas.getContext('webgl2', {antialias : false, preserveDrawingBuffer : true});
  if (!gl) throw new Error('WebGL2 is not available');
  // The atlas: block 0 (32x32 at 0,0) red below row 16, green from it; block 1 (64x32 at 32,0)
  // blue where t0/t1 shade (i < 32), yellow for t2 (i >= 32).
  const image = new OffscreenCanvas(ATLAS_W, ATLAS_H);
  const g = image.getContext('2d');
  g.fillStyle = 'rgb(0,0,0)';
  g.fillRect(0, 0, ATLAS_W, ATLAS_H);
  g.fillStyle = 'rgb(255,0,0)';
  g.fillRect(0, 0, 32, 16);
  g.fillStyle = 'rgb(0,255,0)';
  g.fillRect(0, 16, 32, 16);
  g.fillStyle = 'rgb(0,0,255)';
  g.fillRect(32, 0, 32, 32);
  g.fillStyle = 'rgb(255,255,0)';
  g.fillRect(64, 0, 32, 32);
  // Two strips: tiles 0-2 (block 1 spans tiles 1 and 2), then tiles 3-7.
  const key = buildJpegTiles(ATLAS_W, ATLAS_H, 0, 0,
                             [ await stripOf(image, [ 0, 1, 2 ]), await stripOf(image, [ 3, 4, 5, 6, 7 ]) ]);
  // The delta: tile 0 repainted, its lower half white, and tile 2 resent: one strip of two tiles
  // that are not neighbours (tile 2 comes out of the JPEG at x = 32). Patch 2 removed.
  g.fillStyle = 'rgb(255,255,255)';
  g.fillRect(0, 0, 32, 16);
  const delta = buildJpegTiles(ATLAS_W, ATLAS_H, 1, 0, [ await stripOf(image, [ 0, 2 ]) ]);
  const frames = [ frameMessage(1, [], keyPatches, keyColours, key), frameMessage(2, [ 2 ], [], [], delta) ];

  const patches = new PatchSet(), renderer = new PatchRenderer(gl), atlas = new AtlasTexture(gl, ATLAS_W, ATLAS_H);
  const camera =
      withClipPlanes({eye : [ 0, 0, 3 ], target : [ 0, 0, 0 ], up : [ 0, 1, 0 ], fov : 60, znear : 0, zfar : 0},
                     {min : [ -2, -2, -2 ], max : [ 2, 2, 2 ]});
  window.mirageFrames = [];
  for (let i = 0; i < frames.length; ++i) {
    const m = decodeMessage(frames[i]);
    patches.apply(m);
    await atlas.applyJpegTiles(m.atlas.bytes);
    renderer.draw(patches, atlas, viewProjection(camera, canvas.width / canvas.height), camera.eye,
                  [ 0, 0, canvas.width, canvas.height ]);
    window.mirageFrames.push(canvas.toDataURL('image/png'));
    document.title = `frame ${i + 1}/${frames.length}`;
  }
  // A corrupt payload must be refused with a message, the atlas left alone.
  const bad = key.slice();
  bad[0] = 88;
  let refused = '';
  try {
    await atlas.applyJpegTiles(bad);
  } catch (e) {
    refused = e.message;
  }
  if (!refused.includes('MJT1')) throw new Error(`a corrupt payload was not refused (${refused})`);
  document.title = `done ${frames.length}`;
}

// The atlas texture's bytes (read back through a framebuffer) as a PNG data URL.
function atlasPng(gl, atlas) {
  const framebuffer = gl.createFramebuffer();
  gl.bindFramebuffer(gl.FRAMEBUFFER, framebuffer);
  gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, atlas.texture, 0);
  const pixels = new Uint8ClampedArray(atlas.width * atlas.height * 4);
  gl.readPixels(0, 0, atlas.width, atlas.height, gl.RGBA, gl.UNSIGNED_BYTE, pixels); // sRGB bytes as stored
  gl.bindFramebuffer(gl.FRAMEBUFFER, null);
  const canvas = document.createElement('canvas');
  canvas.width = atlas.width;
  canvas.height = atlas.height;
  canvas.getContext('2d').putImageData(new ImageData(pixels, atlas.width, atlas.height), 0, 0);
  return canvas.toDataURL('image/png');
}

async function runFixture() {
  const fetchBytes = async (name) => {
    const response = await fetch(name);
    if (!response.ok) throw new Error(`${name}: HTTP ${response.status}`);
    return new Uint8Array(await response.arrayBuffer());
  };
  const key = await fetchBytes('key.mjt'), delta = await fetchBytes('delta.mjt');
  const {width, height} = parseJpegTiles(key);
  const gl = document.getElementById('view').getContext('webgl2');
  const atlas = new AtlasTexture(gl, width, height);
  await atlas.applyJpegTiles(key);
  await atlas.applyJpegTiles(delta);
  window.mirageFrames = [ atlasPng(gl, atlas) ];
  document.title = 'done 1';
}

// ?h264=W,H: decodes atlas0.h264, atlas1.h264 (one access unit each) through WebCodecs into a W x H
// atlas and records the texture.
async function runH264(size) {
  const [width, height] = size.split(',').map(Number);
  const gl = document.getElementById('view').getContext('webgl2');
  const atlas = new AtlasTexture(gl, width, height);
  for (let i = 0; i < 2; ++i) {
    const response = await fetch(`atlas${i}.h264`);
    if (!response.ok) throw new Error(`atlas${i}.h264: HTTP ${response.status}`);
    await atlas.applyH264(new Uint8Array(await response.arrayBuffer()), i);
  }
  window.mirageFrames = [ atlasPng(gl, atlas) ];
  document.title = 'done 1';
}

const mode = new URLSearchParams(location.search);
(mode.get('fixture') === '1' ? runFixture()
 : mode.get('h264')          ? runH264(mode.get('h264'))
                             : run())
    .catch((e) => { document.title = `error: ${e.message}`; });
