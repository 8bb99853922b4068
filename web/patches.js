// The client's patch state (mirrors stream::StreamView, src/stream/client_view.cpp, and
// include/mirage/stream/kept_patches.h): the patches held, their colours, and the geometry of
// patches removed in the last KEPT_GEOMETRY_FRAMES frames, which block-only entries bring back;
// the particles of the last frame and the looks they use (docs/stream.md, "Particles").
// A frame that refers to geometry or a look the client does not have throws (the page reports it).

// protocol.h kKeptGeometryFrames: a removal in frame n answers block-only entries through frame
// n + KEPT_GEOMETRY_FRAMES - 1 (frames counted from 1 on the connection).
export const KEPT_GEOMETRY_FRAMES = 256;

// Grid coordinates back to world positions in float32 arithmetic, as protocol.cpp's
// dequantizePosition: sceneMin + q * step.
export function dequantize(q, sceneMin, step) {
  return q.map((v, k) => Math.fround(sceneMin[k] + Math.fround(v * step)));
}

export class PatchSet {
  constructor() {
    this.patches =
        new Map(); // id -> {id, triangleCount, alpha, positions (world), colourOnly, blockLog2, blockX, blockY}
    this.colours = new Map(); // id -> [r, g, b, a] bytes
    this.kept = new Map();    // id -> {patch, frame removed}
    this.removals = [];       // [{frame, ids}], oldest first
    this.looks = new Map();   // particle look id -> {blockLog2, blockX, blockY, rgba} (blockLog2 255: rgba)
    this.particles = [];      // the last frame's: {look (its entry), position (world), size, rotation, rgba}
    this.frames = 0;          // frames applied
    this.version = 0;
    this.sceneMin = [ 0, 0, 0 ];
    this.positionStep = 1;
    this.patchCount = 2 ** 32;
  }

  // The position grid and the patch count of the session.
  setWelcome(welcome) {
    this.sceneMin = welcome.sceneMin;
    this.positionStep = welcome.positionStep;
    this.patchCount = welcome.patchCount;
  }

  // Frame.removed, updated, colours, looks and particles (decoded, sections inflated), in that order.
  apply(frame) {
    const n = ++this.frames;
    while (this.removals.length && this.removals[0].frame + KEPT_GEOMETRY_FRAMES <= n) {
      const {frame : removedIn, ids} = this.removals.shift();
      for (const id of ids)
        if (this.kept.get(id)?.frame === removedIn) this.kept.delete(id);
    }
    if (frame.removed.length) this.removals.push({frame : n, ids : frame.removed});
    for (const id of frame.removed) {
      const held = this.patches.get(id);
      if (!held) throw new Error(`removes patch ${id}, which the client does not hold`);
      this.patches.delete(id);
      this.colours.delete(id);
      this.kept.set(id, {patch : held, frame : n});
    }
    for (const u of frame.updated) {
      if (u.id >= this.patchCount) throw new Error(`patch ${u.id} is past the scene's ${this.patchCount} patches`);
      const held = this.patches.get(u.id);
      let geometry;
      if (u.geometry) {
        if (held) throw new Error(`sends the positions of patch ${u.id}, which the client holds`);
        this.kept.delete(u.id);
        geometry = {
          triangleCount : u.triangleCount,
          alpha : u.alpha,
          positions : u.positions.map((q) => dequantize(q, this.sceneMin, this.positionStep))
        };
      } else if (held) {
        geometry = held;
      } else if (this.kept.has(u.id)) {
        geometry = this.kept.get(u.id).patch;
        this.kept.delete(u.id);
      } else {
        throw new Error(`block-only entry for patch ${u.id}, whose geometry the client does not have`);
      }
      if (geometry.triangleCount !== u.triangleCount)
        throw new Error(`patch ${u.id} has ${geometry.triangleCount} triangles, the entry says ${u.triangleCount}`);
      this.patches.set(u.id, {
        id : u.id,
        triangleCount : u.triangleCount,
        alpha : geometry.alpha,
        positions : geometry.positions,
        colourOnly : u.colourOnly,
        blockLog2 : u.blockLog2,
        blockX : u.blockX,
        blockY : u.blockY
      });
      this.colours.delete(u.id); // a new block or colour-only: a colour (if any) follows in this frame
    }
    for (const c of frame.colours) {
      if (!this.patches.get(c.id)?.colourOnly)
        throw new Error(`colour for patch ${c.id}, which the client does not hold as colour-only`);
      this.colours.set(c.id, c.rgba);
    }
    if (frame.removed.length || frame.updated.length || frame.colours.length) ++this.version;
    this.applyParticles(frame);
  }

  // The frame's looks set, its particles each with its look (held after the looks: else an
  // error); the looks no particle of the frame used are dropped.
  applyParticles(frame) {
    for (const l of frame.looks || []) this.looks.set(l.id, l);
    const used = new Map();
    this.particles = (frame.particles || []).map((p, i) => {
      const look = this.looks.get(p.look);
      if (!look) throw new Error(`particle ${i} of look ${p.look}, which the client does not hold`);
      used.set(p.look, look);
      return {...p, look};
    });
    this.looks = used;
  }
}
