// Atlas decoding into a WebGL2 texture: JPEG tiles (include/mirage/stream/jpeg_tiles.h: the byte
// layout's source) through createImageBitmap, one texSubImage2D per tile; H.264 (Annex B) through
// WebCodecs' VideoDecoder, each decoded frame uploaded whole.
export const JPEG_TILE_SIDE = 32;
const HEADER_BYTES = 24, STRIP_HEADER_BYTES = 8;

// Parses a JPEG tiles payload (Uint8Array) without decoding: {width, height, frame, baseFrame,
// keyframe, strips: [{jpeg, tiles: [{x, y, width, height}]}]}, tile k of a strip at x = 32 k in its
// JPEG. Throws an Error of one line.
export function parseJpegTiles(bytes) {
  if (bytes.length < HEADER_BYTES)
    throw new Error(`JPEG tiles payload of ${bytes.length} bytes, shorter than the 24-byte header`);
  const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  if (String.fromCharCode(bytes[0], bytes[1], bytes[2], bytes[3]) !== 'MJT1')
    throw new Error("not a JPEG tiles payload (magic is not 'MJT1')");
  const width = view.getUint32(4, true), height = view.getUint32(8, true);
  const frame = view.getUint32(12, true), baseFrame = view.getUint32(16, true), stripCount = view.getUint32(20, true);
  if (width === 0 || height === 0 || width > 16384 || height > 16384)
    throw new Error(`JPEG tiles size ${width}x${height} not in 1..16384`);
  const columns = Math.ceil(width / JPEG_TILE_SIDE), tileCount = columns * Math.ceil(height / JPEG_TILE_SIDE);
  if (stripCount > tileCount) throw new Error(`JPEG tiles strip count ${stripCount} over the ${tileCount} tiles`);
  const strips = [];
  let pos = HEADER_BYTES, lastTile = -1;
  for (let s = 0; s < stripCount; ++s) {
    if (bytes.length - pos < STRIP_HEADER_BYTES) throw new Error(`strip ${s}: truncated header`);
    const count = view.getUint16(pos, true), reserved = view.getUint16(pos + 2, true),
          length = view.getUint32(pos + 4, true);
    pos += STRIP_HEADER_BYTES;
    if (count === 0 || count > tileCount) throw new Error(`strip ${s}: ${count} tiles, not in 1..${tileCount}`);
    if (reserved !== 0) throw new Error(`strip ${s}: reserved field ${reserved} not 0`);
    if (count * 4 > bytes.length - pos) throw new Error(`strip ${s}: truncated tile list`);
    const tiles = [];
    for (let k = 0; k < count; ++k, pos += 4) {
      const tile = view.getUint32(pos, true);
      if (tile >= tileCount || tile <= lastTile)
        throw new Error(`strip ${s}: tile ${tile} outside the ${tileCount} tiles or not after tile ${lastTile}`);
      lastTile = tile;
      const x = (tile % columns) * JPEG_TILE_SIDE, y = Math.floor(tile / columns) * JPEG_TILE_SIDE;
      tiles.push({x, y, width : Math.min(JPEG_TILE_SIDE, width - x), height : Math.min(JPEG_TILE_SIDE, height - y)});
    }
    if (length > bytes.length - pos) throw new Error(`strip ${s}: JPEG of ${length} bytes, ${bytes.length - pos} left`);
    strips.push({tiles, jpeg : bytes.subarray(pos, pos + length)});
    pos += length;
  }
  if (pos !== bytes.length) throw new Error(`${bytes.length - pos} bytes after the last JPEG tiles strip`);
  return {width, height, frame, baseFrame, keyframe : frame === baseFrame, strips};
}

// Builds a JPEG tiles payload from strips {tiles: [tile index], jpeg} whose JPEGs are already made
// (the test page's atlas).
export function buildJpegTiles(width, height, frame, baseFrame, strips) {
  let total = HEADER_BYTES;
  for (const s of strips) total += STRIP_HEADER_BYTES + 4 * s.tiles.length + s.jpeg.length;
  const out = new Uint8Array(total);
  const view = new DataView(out.buffer);
  out.set([ 77, 74, 84, 49 ]); // "MJT1"
  [width, height, frame, baseFrame, strips.length].forEach((v, i) => view.setUint32(4 + 4 * i, v, true));
  let pos = HEADER_BYTES;
  for (const s of strips) {
    view.setUint16(pos, s.tiles.length, true);
    view.setUint32(pos + 4, s.jpeg.length, true);
    pos += STRIP_HEADER_BYTES;
    for (const tile of s.tiles) {
      view.setUint32(pos, tile, true);
      pos += 4;
    }
    out.set(s.jpeg, pos);
    pos += s.jpeg.length;
  }
  return out;
}

// The atlas texture and the decoders that fill it. The texture is sRGB (the atlas holds sRGB
// colours): sampling decodes to linear and filters there, as the native client's does.
export class AtlasTexture {
  constructor(gl, width, height) {
    this.gl = gl;
    this.width = width;
    this.height = height;
    this.frame = -1;
    this.texture = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, this.texture);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.CLAMP_TO_EDGE);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.SRGB8_ALPHA8, width, height, 0, gl.RGBA, gl.UNSIGNED_BYTE,
                  new Uint8Array(width * height * 4));
    this.video = null;
    this.videoFrames = []; // resolvers waiting for the next decoded video frame
    // Stacked alpha (docs/stream.md, "Codecs"): a scene with MASK or BLEND materials sends images
    // twice the atlas height, the alpha below the colour as grey. Known from the first image.
    this.stacked = false;
  }

  // A texture twice the atlas height for stacked alpha.
  useStacked() {
    if (this.stacked) return;
    this.stacked = true;
    const gl = this.gl;
    gl.bindTexture(gl.TEXTURE_2D, this.texture);
    gl.texImage2D(gl.TEXTURE_2D, 0, gl.SRGB8_ALPHA8, this.width, 2 * this.height, 0, gl.RGBA, gl.UNSIGNED_BYTE,
                  new Uint8Array(this.width * 2 * this.height * 4));
  }

  // Applies one JPEG tiles payload; resolves when every strip is in the texture. A delta on a frame
  // this texture does not hold is refused (its tiles would patch the wrong image).
  async applyJpegTiles(bytes) {
    const tiles = parseJpegTiles(bytes);
    if (tiles.width !== this.width || (tiles.height !== this.height && tiles.height !== 2 * this.height))
      throw new Error(`JPEG tiles of ${tiles.width}x${tiles.height} for an atlas of ${this.width}x${this.height}`);
    if (tiles.height === 2 * this.height) this.useStacked();
    if (!tiles.keyframe && tiles.baseFrame !== this.frame)
      throw new Error(`JPEG tiles frame ${tiles.frame} is a delta on frame ${tiles.baseFrame}, the atlas holds frame ${
          this.frame}`);
    // Decode every strip first (in parallel), then upload: a strip that fails leaves the atlas alone.
    const bitmaps = await Promise.all(tiles.strips.map(
        (s) =>
            createImageBitmap(new Blob([ s.jpeg ], {type : 'image/jpeg'}),
                              {colorSpaceConversion : 'none', premultiplyAlpha : 'none', imageOrientation : 'none'})));
    const gl = this.gl;
    gl.bindTexture(gl.TEXTURE_2D, this.texture);
    gl.pixelStorei(gl.UNPACK_FLIP_Y_WEBGL, false);
    gl.pixelStorei(gl.UNPACK_PREMULTIPLY_ALPHA_WEBGL, false);
    gl.pixelStorei(gl.UNPACK_COLORSPACE_CONVERSION_WEBGL, gl.NONE);
    tiles.strips.forEach((s, i) => {
      const bitmap = bitmaps[i];
      if (bitmap.width !== s.tiles.length * JPEG_TILE_SIDE || bitmap.height !== JPEG_TILE_SIDE)
        throw new Error(`strip ${i} decodes to ${bitmap.width}x${bitmap.height}, expected ${
            s.tiles.length * JPEG_TILE_SIDE}x${JPEG_TILE_SIDE}`);
    });
    // Each tile is copied out of its strip: WebGL2 applies UNPACK_SKIP_PIXELS to image sources.
    tiles.strips.forEach((s, i) => {
      s.tiles.forEach((t, k) => {
        gl.pixelStorei(gl.UNPACK_SKIP_PIXELS, k * JPEG_TILE_SIDE);
        gl.texSubImage2D(gl.TEXTURE_2D, 0, t.x, t.y, t.width, t.height, gl.RGBA, gl.UNSIGNED_BYTE, bitmaps[i]);
      });
      bitmaps[i].close();
    });
    gl.pixelStorei(gl.UNPACK_SKIP_PIXELS, 0);
    this.frame = tiles.frame;
  }

  // H.264 Annex B access units. Resolves once the frame is decoded and uploaded.
  async applyH264(bytes, timestamp) {
    if (!this.video) {
      this.video = new VideoDecoder({
        output : (frame) => this.uploadVideoFrame(frame),
        error : (e) => {
          for (const w of this.videoFrames.splice(0)) w.reject(e);
        },
      });
      this.video.configure({codec : 'avc1.42E01E', optimizeForLatency : true});
      this.sawKeyframe = false;
    }
    const key = containsIdr(bytes);
    if (!this.sawKeyframe && !key) return; // a decoder starts at an IDR
    this.sawKeyframe = true;
    const waiter = {};
    const done = new Promise((resolve, reject) => Object.assign(waiter, {resolve, reject}));
    this.videoFrames.push(waiter);
    this.video.decode(new EncodedVideoChunk({type : key ? 'key' : 'delta', timestamp, data : bytes}));
    // A decoder that holds a frame back must not stall every later frame: give up waiting after 1 s
    // (the frame still reaches the texture when it comes).
    const timer = setTimeout(() => {
      const i = this.videoFrames.indexOf(waiter);
      if (i >= 0) this.videoFrames.splice(i, 1);
      waiter.resolve();
    }, 1000);
    await done;
    clearTimeout(timer);
  }

  uploadVideoFrame(frame) {
    const gl = this.gl;
    gl.bindTexture(gl.TEXTURE_2D, this.texture);
    // A coded size padded to whole macroblocks keeps the atlas at its top left: only the visible
    // part is copied, at the atlas' own size.
    if (frame.displayHeight === 2 * this.height) this.useStacked();
    const textureHeight = this.stacked ? 2 * this.height : this.height;
    const width = Math.min(frame.displayWidth, this.width), height = Math.min(frame.displayHeight, textureHeight);
    if (width === this.width && height === textureHeight && frame.displayWidth === width &&
        frame.displayHeight === height)
      gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, gl.RGBA, gl.UNSIGNED_BYTE, frame);
    else
      gl.texImage2D(gl.TEXTURE_2D, 0, gl.SRGB8_ALPHA8, frame.displayWidth, frame.displayHeight, 0, gl.RGBA,
                    gl.UNSIGNED_BYTE, frame);
    this.uploadedWidth = frame.displayWidth;
    this.uploadedHeight = frame.displayHeight;
    frame.close();
    const waiter = this.videoFrames.shift();
    if (waiter) waiter.resolve();
  }

  // Texel size the uv divide by (the uploaded video frame's when it differs from the atlas).
  size() {
    return [ this.uploadedWidth || this.width, this.uploadedHeight || (this.stacked ? 2 : 1) * this.height ];
  }
}

// True when the Annex B access unit holds an IDR slice (NAL type 5).
export function containsIdr(bytes) {
  for (let i = 0; i + 3 < bytes.length; ++i)
    if (bytes[i] === 0 && bytes[i + 1] === 0 && bytes[i + 2] === 1 && (bytes[i + 3] & 0x1f) === 5) return true;
  return false;
}

// Whether this browser can decode the H.264 atlas (WebCodecs with Constrained Baseline 3.0).
export async function h264Supported() {
  if (typeof VideoDecoder === 'undefined') return false;
  try {
    const support = await VideoDecoder.isConfigSupported({codec : 'avc1.42E01E', optimizeForLatency : true});
    return !!support.supported;
  } catch {
    return false;
  }
}
