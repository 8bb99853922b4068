// WebGL2 streamed particles (docs/stream.md, "Particles"): each particle of the last frame a
// camera-facing billboard, as the native client draws it (shaders/particle_quad.glsl: in the view
// plane at its centre's depth, turned about the view axis, grown to 1.5 pixels with its alpha
// divided when smaller), textured from its look's block: the tile's mip chain (atlas.js,
// atlasParticleLevelOffset), trilinear between the two levels the pixel's footprint on the tile
// picks; or the look's colour; times the particle's colour. Drawn after the blend patches,
// depth-tested but not written, sorted back to front by view depth and blended on sRGB values: an
// approximation of the native client's per-pixel linked lists, as the blend patches are.
import {COLOUR_ONLY_BLOCK} from './atlas.js';

const VERTEX_SHADER = `#version 300 es
layout(location = 0) in vec3 centre;
layout(location = 1) in vec2 sizeRotation; // billboard edge (world units), rotation (radians)
layout(location = 2) in vec4 colour;       // linear rgb, straight alpha
layout(location = 3) in vec4 block;        // the look's block x, y (texels), log2 (0: colour-only)
layout(location = 4) in vec4 lookColour;   // colour-only looks: sRGB rgb, linear alpha
uniform mat4 viewProj;
uniform vec3 right, up; // the camera's axes in world space
uniform float viewportHeight;
out vec2 tileUv;
flat out vec4 vColour;
flat out vec4 vBlock;
flat out vec4 vLookColour;
const vec2 corners[6] = vec2[](vec2(-1, -1), vec2(1, -1), vec2(1, 1), vec2(-1, -1), vec2(1, 1), vec2(-1, 1));
void main() {
  vec2 c = corners[gl_VertexID];
  float size = sizeRotation.x, rotation = sizeRotation.y;
  // The edge in pixels: the centre and a point one edge up lie at the same view depth.
  vec4 a = viewProj * vec4(centre, 1.0), b = viewProj * vec4(centre + up * size, 1.0);
  float pixels = a.w > 0.0 ? abs(b.y - a.y) / a.w * 0.5 * viewportHeight : 0.0;
  float grow = pixels > 0.0 && pixels < 1.5 ? 1.5 / pixels : 1.0;
  float s = sin(rotation), k = cos(rotation);
  vec2 o = vec2(k * c.x - s * c.y, s * c.x + k * c.y) * (0.5 * size * grow);
  gl_Position = viewProj * vec4(centre + right * o.x + up * o.y, 1.0);
  tileUv = vec2(0.5 + 0.5 * c.x, 0.5 - 0.5 * c.y);
  vColour = vec4(colour.rgb, colour.a / (grow * grow));
  vBlock = block;
  vLookColour = lookColour;
}`;

const FRAGMENT_SHADER = `#version 300 es
precision highp float;
uniform sampler2D atlas;
uniform vec2 atlasSize;    // the texture's texels
uniform float alphaOffset; // stacked alpha: texels from a colour texel down to its alpha; < 0: none
in vec2 tileUv;
flat in vec4 vColour;
flat in vec4 vBlock;
flat in vec4 vLookColour;
out vec4 outColour;
vec3 linearToSrgb(vec3 c) {
  return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, greaterThan(c, vec3(0.0031308)));
}
vec3 srgbToLinear(vec3 c) {
  return mix(c / 12.92, pow((c + 0.055) / 1.055, vec3(2.4)), greaterThan(c, vec3(0.04045)));
}
// Level k of the block: its texel position (atlas.js atlasParticleLevelTexel), sampled in linear.
vec4 level(float h, float k) {
  float side = h / exp2(k);
  float offset = k == 0.0 ? 0.0 : 2.0 * h - 2.0 * side;
  vec2 t = clamp(tileUv * side, vec2(0.5), vec2(side - 0.5));
  vec2 at = vBlock.xy + vec2(offset + t.x, t.y);
  vec4 c = texture(atlas, at / atlasSize); // sRGB texture: filtered in linear
  // Codecs without alpha (H.264, JPEG) stack it below the colour as grey: its R, encoded back.
  if (alphaOffset >= 0.0) c.a = linearToSrgb(texture(atlas, (at + vec2(0.0, alphaOffset)) / atlasSize).rrr).r;
  return c;
}
void main() {
  vec4 t;
  if (vBlock.z == 0.0) {
    t = vec4(srgbToLinear(vLookColour.rgb), vLookColour.a);
  } else {
    float h = exp2(vBlock.z);
    vec2 texel = tileUv * h; // level 0's texels a pixel steps over pick the level
    float rho = max(length(dFdx(texel)), length(dFdy(texel)));
    float lod = clamp(log2(max(rho, 1e-8)), 0.0, vBlock.z);
    float fine = floor(lod);
    t = mix(level(h, fine), level(h, min(fine + 1.0, vBlock.z)), lod - fine);
  }
  vec4 c = vColour * t;
  if (c.a < 1.0 / 512.0) discard; // below an 8-bit step (as the native client)
  // The canvas is not an sRGB target: blending happens on sRGB values.
  outColour = vec4(linearToSrgb(c.rgb), c.a);
}`;

const FLOATS_PER_PARTICLE = 17; // centre 3, size and rotation 2, colour 4, block 4, look colour 4

function compile(gl, type, source) {
  const shader = gl.createShader(type);
  gl.shaderSource(shader, source);
  gl.compileShader(shader);
  if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) throw new Error(`shader: ${gl.getShaderInfoLog(shader)}`);
  return shader;
}

export class ParticleRenderer {
  constructor(gl) {
    this.gl = gl;
    const program = gl.createProgram();
    gl.attachShader(program, compile(gl, gl.VERTEX_SHADER, VERTEX_SHADER));
    gl.attachShader(program, compile(gl, gl.FRAGMENT_SHADER, FRAGMENT_SHADER));
    gl.linkProgram(program);
    if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw new Error(`program: ${gl.getProgramInfoLog(program)}`);
    this.program = program;
    this.uniforms = {};
    for (const name of ['viewProj', 'right', 'up', 'viewportHeight', 'atlasSize', 'alphaOffset'])
      this.uniforms[name] = gl.getUniformLocation(program, name);
    this.vao = gl.createVertexArray();
    this.buffer = gl.createBuffer();
    gl.bindVertexArray(this.vao);
    gl.bindBuffer(gl.ARRAY_BUFFER, this.buffer);
    const stride = FLOATS_PER_PARTICLE * 4;
    [[ 0, 3, 0 ], [ 1, 2, 3 ], [ 2, 4, 5 ], [ 3, 4, 9 ], [ 4, 4, 13 ]].forEach(([ location, size, offset ]) => {
      gl.enableVertexAttribArray(location);
      gl.vertexAttribPointer(location, size, gl.FLOAT, false, stride, offset * 4);
      gl.vertexAttribDivisor(location, 1); // one record per instance
    });
    gl.bindVertexArray(null);
  }

  // The particles of `set` (PatchSet) drawn into the bound framebuffer (viewport and depth set by
  // the caller) from the camera of `view` (its world -> view matrix, column-major) and `viewProj`.
  draw(set, atlas, viewProj, view, eye, viewportHeight) {
    const particles = set.particles;
    if (!particles.length || !atlas) return;
    const gl = this.gl;
    const right = [ view[0], view[4], view[8] ], up = [ view[1], view[5], view[9] ];
    const forward = [ -view[2], -view[6], -view[10] ];
    const depth = (p) => (p.position[0] - eye[0]) * forward[0] + (p.position[1] - eye[1]) * forward[1] +
                         (p.position[2] - eye[2]) * forward[2];
    const sorted = particles.map((p) => ({p, d : depth(p)})).sort((a, b) => b.d - a.d); // far first
    const data = new Float32Array(sorted.length * FLOATS_PER_PARTICLE);
    sorted.forEach(({p}, i) => {
      const l = p.look, colourOnly = l.blockLog2 === COLOUR_ONLY_BLOCK;
      data.set(
          [
            ...p.position, p.size, p.rotation, ...p.rgba.map((v) => v / 255), l.blockX, l.blockY,
            colourOnly ? 0 : l.blockLog2, 0, ...l.rgba.map((v) => v / 255)
          ],
          i * FLOATS_PER_PARTICLE);
    });
    gl.bindBuffer(gl.ARRAY_BUFFER, this.buffer);
    gl.bufferData(gl.ARRAY_BUFFER, data, gl.STREAM_DRAW);
    gl.useProgram(this.program);
    gl.uniformMatrix4fv(this.uniforms.viewProj, false, viewProj);
    gl.uniform3f(this.uniforms.right, ...right);
    gl.uniform3f(this.uniforms.up, ...up);
    gl.uniform1f(this.uniforms.viewportHeight, viewportHeight);
    gl.uniform2f(this.uniforms.atlasSize, ...atlas.size());
    gl.uniform1f(this.uniforms.alphaOffset, atlas.stacked ? atlas.height : -1);
    gl.activeTexture(gl.TEXTURE0);
    gl.bindTexture(gl.TEXTURE_2D, atlas.texture);
    gl.enable(gl.DEPTH_TEST);
    gl.depthFunc(gl.LESS);
    gl.depthMask(false);
    gl.disable(gl.CULL_FACE);
    gl.enable(gl.BLEND);
    gl.blendFuncSeparate(gl.SRC_ALPHA, gl.ONE_MINUS_SRC_ALPHA, gl.ONE, gl.ONE_MINUS_SRC_ALPHA);
    gl.bindVertexArray(this.vao);
    gl.drawArraysInstanced(gl.TRIANGLES, 0, 6, sorted.length);
    gl.bindVertexArray(null);
    gl.disable(gl.BLEND);
    gl.depthMask(true);
  }
}
