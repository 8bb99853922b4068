// A server-free test of the client: a hard-coded patch set, particles and a generated atlas go
// through the same code as a served stream (Frame bytes -> decodeMessage -> PatchSet -> JPEG tiles
// -> WebGL2). Two frames: a keyframe with two particles (a look with a block, a colour-only look),
// then a delta that repaints one tile, removes a patch and keeps one particle of the look the
// client holds. Then the patch state's rules (PatchSet) and the patch and particle section parsers
// against the C++ encoder's exact bytes.
// ?fixture=1: decodes key.mjt then delta.mjt (written by the C++ JpegTileEncoder next to this page)
// and records the atlas texture itself, for a comparison with the encoder's source image.
// tests/stream_web/browser_test.py renders this page with scripts/browser_client.py and checks pixels;
// the scene below and the expectations there are written together (change both).
import {decodeMessage, parsePatchSection, parseParticleSection} from './protocol.js';
import {buildJpegTiles, parseJpegTiles, AtlasTexture} from './atlas_codec.js';
import {PatchSet} from './patches.js';
import {PatchRenderer} from './renderer.js';
import {lookAt, viewProjection, withClipPlanes} from './camera.js';

const ATLAS_W = 128, ATLAS_H = 64;
// The position grid of this scene (a Welcome's sceneMin and positionStep).
const GRID = {
  sceneMin : [ -2, -2, -2 ],
  positionStep : 1 / 1024,
  patchCount : 100
};

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

// Particles: look 7 with a block (the atlas's 32 x 16 at (0, 32): level 0 orange above its middle
// row, purple below), colour-only look 8 (green); in frame 1 a white particle of look 7 (rotation
// 0: the tile's top row up) and a half-transparent one of look 8, in frame 2 the first alone (its
// look held: no entry).
const LOOK_BLOCK = {
  id : 7,
  blockLog2 : 4,
  blockX : 0,
  blockY : 32
};
const LOOK_COLOUR = {
  id : 8,
  blockLog2 : 255,
  rgba : [ 0, 255, 0, 255 ]
};
const PARTICLE_A = {
  look : 7,
  position : [ 1.2, -0.9, 0.5 ],
  size : 0.4,
  rotation : 0,
  rgba : [ 255, 255, 255, 255 ]
};
const PARTICLE_B = {
  look : 8,
  position : [ -1.5, 1.0, 0.5 ],
  size : 0.3,
  rotation : 0.5,
  rgba : [ 255, 255, 255, 128 ]
};

// An IEEE half of v (normal numbers, rounded; tiny ones 0).
function toHalf(v) {
  const b = new Uint32Array(new Float32Array([ v ]).buffer)[0];
  const e = ((b >>> 23) & 0xff) - 127 + 15;
  return e <= 0 ? 0 : ((b >>> 16) & 0x8000) | ((e << 10) + Math.round((b & 0x7fffff) / 8192));
}

// A raw particle section (particle_section.cpp): the looks, then the particles in columns on the
// grid of GRID (origin sceneMin, step positionStep).
function particleSection(looks, particles) {
  const out = [];
  const varint = (v) => {
    for (; v >= 0x80; v = Math.floor(v / 128)) out.push((v % 128) | 0x80);
    out.push(v);
  };
  const u16 = (v) => out.push(v & 0xff, (v >>> 8) & 0xff);
  varint(looks.length);
  let next = 0;
  for (const l of looks) {
    varint(l.id - next);
    next = l.id + 1;
    out.push(l.blockLog2);
    if (l.blockLog2 === 255) {
      out.push(...l.rgba);
    } else {
      varint(l.blockX >> l.blockLog2);
      varint(l.blockY >> l.blockLog2);
    }
  }
  varint(particles.length);
  if (!particles.length) return out;
  const f32 = new Uint8Array(new Float32Array([...GRID.sceneMin, GRID.positionStep ]).buffer);
  out.push(...f32);
  particles.forEach((p) => varint(p.look));
  for (let k = 0; k < 3; ++k)
    particles.forEach((p) => u16(Math.round((p.position[k] - GRID.sceneMin[k]) / GRID.positionStep)));
  particles.forEach((p) => u16(toHalf(p.size)));
  particles.forEach((p) => u16(Math.round(p.rotation / (2 * Math.PI) * 65536) & 0xffff));
  particles.forEach((p) => out.push(...p.rgba));
  return out;
}

// Frame message bytes, laid out as src/stream/protocol.cpp and patch_section.cpp write them (a raw
// patch section). Patches: world positions, quantized on GRID; `geometry: false` makes a block-only
// entry. atlasBytes null: no atlas. `particles`: {looks, particles} of a raw particle section.
function frameMessage(sequence, removed, updated, colours, atlasBytes, particles = {
  looks : [],
  particles : []
}) {
  const section = [];
  const varint = (v) => {
    for (; v >= 0x80; v = Math.floor(v / 128)) section.push((v % 128) | 0x80);
    section.push(v);
  };
  const zigzag = (v) => (v < 0 ? -2 * v - 1 : 2 * v);
  let next = 0;
  const gap = (id) => {
    const g = id - next;
    next = id + 1;
    return g;
  };
  varint(removed.length);
  removed.forEach((id) => varint(gap(id)));
  varint(updated.length);
  next = 0;
  let previousA = [ 0, 0, 0 ];
  for (const p of updated) {
    const geometry = p.geometry !== false, colourOnly = p.blockLog2 === 255;
    varint(gap(p.id));
    section.push(p.triangleCount | (geometry ? (p.alpha << 2) | 0x10 : 0) | (colourOnly ? 0x20 : 0));
    if (!colourOnly) {
      section.push(p.blockLog2);
      varint(p.blockX >> p.blockLog2);
      varint(p.blockY >> p.blockLog2);
    }
    if (!geometry) continue;
    const q = p.positions.map((v) => v.map((x, k) => Math.round((x - GRID.sceneMin[k]) / GRID.positionStep)));
    const at = (v, k) => q[v][k];
    const predict = [
      (k) => previousA[k], (k) => at(0, k), (k) => at(0, k), (k) => at(1, k) + at(2, k) - at(0, k),
      (k) => at(1, k) + at(3, k) - at(2, k)
    ];
    q.forEach((v, i) => v.forEach((x, k) => varint(zigzag(x - predict[i](k)))));
    previousA = q[0];
  }
  varint(colours.length);
  next = 0;
  for (const c of colours) {
    varint(gap(c.id));
    section.push(...c.rgba);
  }

  const bytes = [];
  const u8 = (v) => bytes.push(v & 0xff);
  const u16 = (v) => {
    u8(v);
    u8(v >>> 8);
  };
  const u32 = (v) => {
    for (let i = 0; i < 4; ++i) u8(v >>> (8 * i));
  };
  [77, 82, 71, 83].forEach(u8);
  u16(3);
  u16(4);
  u32(0);
  u32(sequence);
  u32(sequence);
  u32(0);
  u32(0);
  u8(0); // raw patch section
  u32(section.length);
  bytes.push(...section);
  const particleBytes = particleSection(particles.looks, particles.particles);
  u8(0); // raw particle section
  u32(particleBytes.length);
  bytes.push(...particleBytes);
  const atlas = atlasBytes || new Uint8Array(0);
  u8(atlasBytes ? 3 : 0);
  u32(atlasBytes ? ATLAS_W : 0);
  u32(atlasBytes ? ATLAS_H : 0);
  u32(atlas.length);
  const out = new Uint8Array(bytes.length + atlas.length);
  out.set(bytes);
  out.set(atlas, bytes.length);
  new DataView(out.buffer).setUint32(8, out.length - 12, true);
  return out.buffer;
}

// Throws unless f() throws an Error whose message includes `part`.
function expectThrow(f, part) {
  try {
    f();
  } catch (e) {
    if (e.message.includes(part)) return;
    throw new Error(`expected an error with '${part}', got '${e.message}'`);
  }
  throw new Error(`expected an error with '${part}', none came`);
}

function check(ok, what) {
  if (!ok) throw new Error(what);
}

// PatchSet's rules, after frames 1 (keyPatches) and 2 (patch 2 removed): the mirror of StreamView's.
function checkPatchState(patches) {
  const blockOnly = (id, triangleCount, blockLog2 = 255, blockX = 0) =>
      ({id, triangleCount, geometry : false, blockLog2, blockX, blockY : 0});
  const apply = (updated, removed = []) => patches.apply(decodeMessage(frameMessage(9, removed, updated, [], null)));
  check(patches.kept.has(2) && !patches.patches.has(2), 'patch 2 kept after its removal');
  apply([ blockOnly(2, 1) ]); // frame 3: back from the kept geometry
  check(Math.abs(patches.patches.get(2)?.positions[1][0] - keyPatches[2].positions[1][0]) <= GRID.positionStep / 2,
        'patch 2 back with its positions');
  apply([ blockOnly(0, 2, 5, 64) ]); // frame 4: patch 0 moved, its geometry held
  check(patches.patches.get(0).blockX === 64 && patches.patches.get(0).positions[3][1] === 0.5, 'patch 0 moved');
  expectThrow(() => apply([ blockOnly(42, 1) ]),
              'block-only entry for patch 42, whose geometry the client does not have');
  expectThrow(() => apply([ keyPatches[0] ]), 'sends the positions of patch 0, which the client holds');
  expectThrow(() => apply([ blockOnly(1, 2, 5, 64) ]), 'patch 1 has 3 triangles, the entry says 2');
  expectThrow(() => apply([], [ 77 ]), 'removes patch 77, which the client does not hold');
  expectThrow(() => apply([ {...keyPatches[0], id : 100} ]), 'patch 100 is past the scene\'s 100 patches');
  // The keep window: a removal answers block-only entries for KEPT_GEOMETRY_FRAMES frames.
  apply([], [ 4 ]);
  for (let i = 0; i < 255; ++i) apply([]);
  expectThrow(() => apply([ blockOnly(4, 2) ]), 'block-only entry for patch 4');

  // Particles: a look held from the frame before serves without an entry; one no particle used is
  // dropped; a particle of a look the client does not hold is an error.
  const frameOf = (looks, particles) => decodeMessage(frameMessage(9, [], [], [], null, {looks, particles}));
  patches.apply(frameOf([ LOOK_BLOCK, LOOK_COLOUR ], [ PARTICLE_A, PARTICLE_B ]));
  check(patches.looks.size === 2 && patches.particles.length === 2, 'two looks, two particles');
  patches.apply(frameOf([], [ PARTICLE_B ]));
  check(patches.looks.size === 1 && patches.particles[0].look.rgba[1] === 255, 'look 8 held, look 7 dropped');
  expectThrow(() => patches.apply(frameOf([], [ PARTICLE_A ])), 'particle 0 of look 7, which the client does not hold');
}

// The bytes of StreamPatchSection.ExactLayout (tests/stream/patch_section_test.cpp): the C++ encoder's
// layout, parsed here.
function checkExactLayout() {
  const bytes = new Uint8Array(
      [ 2, 3, 1, 2, 2, 0x1a, 4, 2, 1, 20, 40, 60, 6, 0, 0, 0, 8, 0, 0, 0, 2, 6, 0x21, 1, 9, 1, 2, 3, 4 ]);
  const f = {};
  parsePatchSection(bytes, f);
  const expected = {
    removed : [ 3, 5 ],
    updated : [
      {
        id : 2,
        triangleCount : 2,
        geometry : true,
        alpha : 2,
        colourOnly : false,
        blockLog2 : 4,
        blockX : 32,
        blockY : 16,
        positions : [ [ 10, 20, 30 ], [ 13, 20, 30 ], [ 10, 24, 30 ], [ 13, 24, 31 ] ]
      },
      {
        id : 9,
        triangleCount : 1,
        geometry : false,
        alpha : 0,
        colourOnly : true,
        blockLog2 : 255,
        blockX : 0,
        blockY : 0
      }
    ],
    colours : [ {id : 9, rgba : [ 1, 2, 3, 4 ]} ]
  };
  check(JSON.stringify(f) === JSON.stringify(expected), `patch section parsed as ${JSON.stringify(f)}`);
  const bad = bytes.slice();
  bad[5] = 0x1e; // alpha 3
  expectThrow(() => parsePatchSection(bad, {}), 'updated[0].alpha 3 not an alpha mode');
  expectThrow(() => parsePatchSection(new Uint8Array([ 0x80, 0 ]), {}),
              'removed count varint not in its shortest form');
  expectThrow(() => parsePatchSection(new Uint8Array([ 9, 1 ]), {}), 'removed count 9 entries need 9 bytes, 1 left');
  expectThrow(() => parsePatchSection(new Uint8Array([ 0, 0, 0, 0 ]), {}), 'patches 1 bytes after the colours');
}

// The bytes of StreamParticleSection.ExactLayout (tests/stream/particle_section_test.cpp).
function checkParticleLayout() {
  const bytes = new Uint8Array([
    2, 2, 3,    2,    1, 2,    255, 1,    2, 3, 4,  2,  0,  0,  0x80, 0x3f, 0, 0, 0, 0x40,
    0, 0, 0x40, 0x40, 0, 0,    0,   0x3f, 2, 5, 1,  0,  0,  1,  2,    0,    0, 0, 3, 0,
    7, 0, 0,    0x3c, 0, 0x38, 0,   0x40, 0, 0, 10, 20, 30, 40, 5,    6,    7, 8
  ]);
  const f = {};
  parseParticleSection(bytes, f);
  const expected = {
    looks : [
      {id : 2, blockLog2 : 3, blockX : 16, blockY : 8, rgba : [ 0, 0, 0, 0 ]},
      {id : 5, blockLog2 : 255, blockX : 0, blockY : 0, rgba : [ 1, 2, 3, 4 ]}
    ],
    particles : [
      {look : 2, position : [ 1.5, 3, 4.5 ], size : 1, rotation : Math.PI / 2, rgba : [ 10, 20, 30, 40 ]},
      {look : 5, position : [ 129, 2, 6.5 ], size : 0.5, rotation : 0, rgba : [ 5, 6, 7, 8 ]}
    ],
    particleOrigin : [ 1, 2, 3 ],
    particleStep : 0.5
  };
  check(JSON.stringify(f) === JSON.stringify(expected), `particle section parsed as ${JSON.stringify(f)}`);
  const unused = bytes.slice();
  unused[28] = 5; // the first particle of look 5 too: look 2 unused
  expectThrow(() => parseParticleSection(unused, {}), 'looks[0] look 2 is used by no particle of the frame');
  const negative = bytes.slice();
  negative[43] = 0xbc; // the first size: -1
  expectThrow(() => parseParticleSection(negative, {}), 'particles[0].size not a finite non-negative half');
  expectThrow(() => parseParticleSection(new Uint8Array([ 0, 9, 1 ]), {}),
              'particles count 9 entries need 135 bytes, 1 left');
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
  // Look 7's block (32 x 16 at 0, 32): orange rows above its middle, purple below.
  g.fillStyle = 'rgb(255,128,0)';
  g.fillRect(0, 32, 32, 8);
  g.fillStyle = 'rgb(128,0,255)';
  g.fillRect(0, 40, 32, 8);
  // Two strips: tiles 0-2 (block 1 spans tiles 1 and 2), then tiles 3-7.
  const key = buildJpegTiles(ATLAS_W, ATLAS_H, 0, 0,
                             [ await stripOf(image, [ 0, 1, 2 ]), await stripOf(image, [ 3, 4, 5, 6, 7 ]) ]);
  // The delta: tile 0 repainted, its lower half white, and tile 2 resent: one strip of two tiles
  // that are not neighbours (tile 2 comes out of the JPEG at x = 32). Patch 2 removed.
  g.fillStyle = 'rgb(255,255,255)';
  g.fillRect(0, 0, 32, 16);
  const delta = buildJpegTiles(ATLAS_W, ATLAS_H, 1, 0, [ await stripOf(image, [ 0, 2 ]) ]);
  const frames = [
    frameMessage(1, [], keyPatches, keyColours, key,
                 {looks : [ LOOK_BLOCK, LOOK_COLOUR ], particles : [ PARTICLE_A, PARTICLE_B ]}),
    frameMessage(2, [ 2 ], [], [], delta, {looks : [], particles : [ PARTICLE_A ]})
  ];

  const patches = new PatchSet(), renderer = new PatchRenderer(gl), atlas = new AtlasTexture(gl, ATLAS_W, ATLAS_H);
  patches.setWelcome(GRID);
  const camera =
      withClipPlanes({eye : [ 0, 0, 3 ], target : [ 0, 0, 0 ], up : [ 0, 1, 0 ], fov : 60, znear : 0, zfar : 0},
                     {min : [ -2, -2, -2 ], max : [ 2, 2, 2 ]});
  window.mirageFrames = [];
  for (let i = 0; i < frames.length; ++i) {
    const m = decodeMessage(frames[i]);
    patches.apply(m);
    await atlas.applyJpegTiles(m.atlas.bytes);
    renderer.draw(patches, atlas, viewProjection(camera, canvas.width / canvas.height), camera.eye,
                  [ 0, 0, canvas.width, canvas.height ], true, lookAt(camera.eye, camera.target, camera.up));
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
  checkPatchState(patches);
  checkExactLayout();
  checkParticleLayout();
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
