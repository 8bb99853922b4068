// WebGL2 patch renderer: every patch the server sent, its triangles at their world positions,
// textured from the atlas by the shared layout (atlas.js mirrors shaderio/atlas.h), or drawn in its
// colour when it did not fit in the atlas. Opaque and mask patches first with depth; blend patches
// after them, depth-tested but not written, sorted back to front by patch centroid. That sort is an
// approximation of the native client's per-pixel linked lists: intersecting or cyclically
// overlapping transparent patches can blend in the wrong order here. Then the particles
// (particles.js), sorted among themselves.
import {atlasCornerTexel, atlasTriangleVertex} from './atlas.js';
import {ParticleRenderer} from './particles.js';
import {AlphaMode} from './protocol.js';
import {sub, dot} from './camera.js';

const VERTEX_SHADER = `#version 300 es
layout(location = 0) in vec3 position;
layout(location = 1) in vec2 texel;     // atlas texel position (texel centres at .5)
layout(location = 2) in vec4 colour;    // colour-only patches: sRGB rgb, linear alpha
layout(location = 3) in float flags;    // 0 textured, 1 colour-only; + 2 mask, + 4 blend
uniform mat4 viewProj;
uniform vec2 atlasSize;   // the texture's texels
uniform float alphaOffset; // stacked alpha: texels from a colour texel down to its alpha; < 0: none
out vec2 uv;
out vec2 alphaUv;
out vec4 vColour;
flat out int vFlags;
void main() {
  uv = texel / atlasSize;
  alphaUv = alphaOffset < 0.0 ? vec2(-1.0) : (texel + vec2(0.0, alphaOffset)) / atlasSize;
  vColour = colour;
  vFlags = int(flags);
  gl_Position = viewProj * vec4(position, 1.0);
}`;

const FRAGMENT_SHADER = `#version 300 es
precision highp float;
uniform sampler2D atlas;
in vec2 uv;
in vec2 alphaUv;
in vec4 vColour;
flat in int vFlags;
out vec4 outColour;
vec3 linearToSrgb(vec3 c) {
  return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, greaterThan(c, vec3(0.0031308)));
}
void main() {
  vec4 c;
  if ((vFlags & 1) != 0) {
    c = vColour;  // already sRGB
  } else {
    vec4 t = texture(atlas, uv);  // sRGB texture: filtered in linear
    c = vec4(linearToSrgb(t.rgb), t.a);
    // Codecs without alpha (H.264, JPEG) stack it below the colour as grey: its R, encoded back.
    if (alphaUv.x >= 0.0) c.a = linearToSrgb(texture(atlas, alphaUv).rrr).r;
  }
  if ((vFlags & 2) != 0 && c.a < 0.5) discard;
  if ((vFlags & 4) == 0) c.a = 1.0;
  // The canvas is not an sRGB target: blending happens on sRGB values (the native client blends in linear).
  outColour = c;
}`;

// The forward renderer's background (render::RenderSettings::background, linear RGB), encoded as
// the canvas holds it (sRGB), so empty pixels match `mirage render`.
const BACKGROUND_LINEAR = [ 0.02, 0.022, 0.026 ];
const BACKGROUND_SRGB =
    BACKGROUND_LINEAR.map((c) => (c <= 0.0031308 ? 12.92 * c : 1.055 * Math.pow(c, 1 / 2.4) - 0.055));

const FLOATS_PER_VERTEX = 10; // position 3, texel 2, colour 4, flags 1

function compile(gl, type, source) {
  const shader = gl.createShader(type);
  gl.shaderSource(shader, source);
  gl.compileShader(shader);
  if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) throw new Error(`shader: ${gl.getShaderInfoLog(shader)}`);
  return shader;
}

export class PatchRenderer {
  constructor(gl) {
    this.gl = gl;
    const program = gl.createProgram();
    gl.attachShader(program, compile(gl, gl.VERTEX_SHADER, VERTEX_SHADER));
    gl.attachShader(program, compile(gl, gl.FRAGMENT_SHADER, FRAGMENT_SHADER));
    gl.linkProgram(program);
    if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw new Error(`program: ${gl.getProgramInfoLog(program)}`);
    this.program = program;
    this.viewProjLocation = gl.getUniformLocation(program, 'viewProj');
    this.atlasSizeLocation = gl.getUniformLocation(program, 'atlasSize');
    this.alphaOffsetLocation = gl.getUniformLocation(program, 'alphaOffset');
    this.opaque = this.makeBatch();
    this.blend = this.makeBatch();
    this.builtVersion = -1;
    this.blendPatches = [];
    this.particles = new ParticleRenderer(gl);
  }

  makeBatch() {
    const gl = this.gl;
    const vao = gl.createVertexArray(), buffer = gl.createBuffer();
    gl.bindVertexArray(vao);
    gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
    const stride = FLOATS_PER_VERTEX * 4;
    [[ 0, 3, 0 ], [ 1, 2, 3 ], [ 2, 4, 5 ], [ 3, 1, 9 ]].forEach(([ location, size, offset ]) => {
      gl.enableVertexAttribArray(location);
      gl.vertexAttribPointer(location, size, gl.FLOAT, false, stride, offset * 4);
    });
    gl.bindVertexArray(null);
    return {vao, buffer, count : 0};
  }

  // Writes one patch's triangles into `out` at `offset` floats; returns the new offset.
  static writePatch(out, offset, patch, rgba) {
    const colourOnly = patch.colourOnly;
    const flags =
        (colourOnly ? 1 : 0) + (patch.alpha === AlphaMode.Mask ? 2 : 0) + (patch.alpha === AlphaMode.Blend ? 4 : 0);
    const colour = rgba ? rgba.map((v) => v / 255) : [ 0.5, 0.5, 0.5, 1 ];
    for (let t = 0; t < patch.triangleCount; ++t)
      for (let corner = 0; corner < 3; ++corner) {
        const v = atlasTriangleVertex(t, corner);
        const p = patch.positions[v];
        const texel = colourOnly ? [ 0, 0 ] : atlasCornerTexel(v, patch.blockLog2);
        out.set([ p[0], p[1], p[2], patch.blockX + texel[0], patch.blockY + texel[1], ...colour, flags ], offset);
        offset += FLOATS_PER_VERTEX;
      }
    return offset;
  }

  upload(batch, patches, colours) {
    let triangles = 0;
    for (const p of patches) triangles += p.triangleCount;
    const data = new Float32Array(triangles * 3 * FLOATS_PER_VERTEX);
    let offset = 0;
    for (const p of patches) offset = PatchRenderer.writePatch(data, offset, p, colours.get(p.id));
    const gl = this.gl;
    gl.bindBuffer(gl.ARRAY_BUFFER, batch.buffer);
    gl.bufferData(gl.ARRAY_BUFFER, data, gl.DYNAMIC_DRAW);
    batch.count = triangles * 3;
  }

  // Draws the patch set into the bound framebuffer's `viewport` ([x, y, w, h]). `eye` sorts blend
  // patches. With `view` (the camera's world -> view matrix) the set's particles too (particles.js).
  draw(set, atlas, viewProj, eye, viewport, clear = true, view = null) {
    const gl = this.gl;
    if (this.builtVersion !== set.version) {
      const opaque = [];
      this.blendPatches = [];
      for (const p of set.patches.values()) {
        if (p.alpha === AlphaMode.Blend) {
          const n = p.triangleCount + 2;
          const c = [ 0, 0, 0 ];
          for (let v = 0; v < n; ++v)
            for (let k = 0; k < 3; ++k) c[k] += p.positions[v][k] / n;
          this.blendPatches.push({patch : p, centroid : c});
        } else {
          opaque.push(p);
        }
      }
      this.upload(this.opaque, opaque, set.colours);
      this.builtVersion = set.version;
      this.sortedFor = null;
    }
    gl.viewport(...viewport);
    gl.enable(gl.SCISSOR_TEST);
    gl.scissor(...viewport);
    if (clear) {
      gl.clearColor(...BACKGROUND_SRGB, 1);
      gl.clearDepth(1);
      gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    }
    gl.useProgram(this.program);
    gl.uniformMatrix4fv(this.viewProjLocation, false, viewProj);
    gl.uniform2f(this.atlasSizeLocation, ...(atlas ? atlas.size() : [ 1, 1 ]));
    gl.uniform1f(this.alphaOffsetLocation, atlas && atlas.stacked ? atlas.height : -1);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, atlas ? atlas.texture : null);
    gl.enable(gl.DEPTH_TEST);
    gl.depthFunc(gl.LESS);
    gl.depthMask(true);
    gl.disable(gl.BLEND);
    gl.disable(gl.CULL_FACE); // patches are drawn two-sided, as the atlas shades both sides alike
    gl.bindVertexArray(this.opaque.vao);
    gl.drawArrays(gl.TRIANGLES, 0, this.opaque.count);

    if (this.blendPatches.length) {
      // Back to front from this eye (far centroids first).
      const key = eye.join(',');
      if (this.sortedFor !== key) {
        for (const b of this.blendPatches) {
          const d = sub(b.centroid, eye);
          b.distance = dot(d, d);
        }
        this.blendPatches.sort((a, b) => b.distance - a.distance);
        this.upload(this.blend, this.blendPatches.map((b) => b.patch), set.colours);
        this.sortedFor = key;
      }
      gl.enable(gl.BLEND);
      gl.blendFuncSeparate(gl.SRC_ALPHA, gl.ONE_MINUS_SRC_ALPHA, gl.ONE, gl.ONE_MINUS_SRC_ALPHA);
      gl.depthMask(false);
      gl.bindVertexArray(this.blend.vao);
      gl.drawArrays(gl.TRIANGLES, 0, this.blend.count);
      gl.depthMask(true);
      gl.disable(gl.BLEND);
    }
    gl.bindVertexArray(null);
    if (view) this.particles.draw(set, atlas, viewProj, view, eye, viewport[3]);
    gl.disable(gl.SCISSOR_TEST);
  }
}
