#include "mirage/io/image_io.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <system_error>
#include <vector>

#include <unistd.h>

#include <stb/stb_image.h>
#include <stb/stb_image_write.h>

#include "mirage/core/temp_files.h"
#include "mirage/core/input_text.h"

namespace mirage::io {

namespace {

std::string name(const std::filesystem::path& p) { return p.string(); }

Result<std::vector<uint8_t>> readAll(const std::filesystem::path& path) {
  if (std::string problem = inputFileProblem(path); !problem.empty()) return makeError(name(path), problem);
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) return makeError(name(path), std::string("cannot open: ") + std::strerror(errno));
  std::streamsize size = in.tellg();
  if (size < 0) return makeError(name(path), "cannot determine size");
  std::vector<uint8_t> bytes(static_cast<size_t>(size));
  in.seekg(0);
  if (size > 0 && !in.read(reinterpret_cast<char*>(bytes.data()), size)) return makeError(name(path), "read failed");
  return bytes;
}

Status checkImage(const std::filesystem::path& path, uint32_t w, uint32_t h, size_t have, size_t perPixel) {
  if (w == 0 || h == 0) return makeError(name(path), "cannot write an empty image (0 pixels)");
  if (have != size_t(w) * h * perPixel) return makeError(name(path), "pixel data does not match image size");
  return Ok{};
}

// Little-endian appenders for the EXR and PFM encoders (x86/ARM hosts are little-endian; the
// static_assert below keeps a big-endian port from silently writing garbage).
static_assert(std::endian::native == std::endian::little, "EXR/PFM writers assume a little-endian host");
template <class T> void put(std::vector<uint8_t>& out, T value) {
  const auto* p = reinterpret_cast<const uint8_t*>(&value);
  out.insert(out.end(), p, p + sizeof(T));
}
void putString(std::vector<uint8_t>& out, const char* s) { out.insert(out.end(), s, s + std::strlen(s) + 1); }
void putAttribute(std::vector<uint8_t>& out, const char* attrName, const char* type, const std::vector<uint8_t>& v) {
  putString(out, attrName);
  putString(out, type);
  put<int32_t>(out, int32_t(v.size()));
  out.insert(out.end(), v.begin(), v.end());
}

constexpr uint32_t kExrMagic = 20000630; // bytes 76 2f 31 01
constexpr int32_t kExrFloat = 2;
// EXR channels are stored sorted by name; for RGBA that is A, B, G, R (source offsets 3, 2, 1, 0).
constexpr std::array<const char*, 4> kExrChannels = {"A", "B", "G", "R"};
constexpr std::array<int, 4> kExrSource = {3, 2, 1, 0};

} // namespace

Status writeFileAtomic(const std::filesystem::path& path, const void* data, size_t size) {
  std::span<const uint8_t> part(static_cast<const uint8_t*>(data), size);
  return writeFileAtomic(path, std::span<const std::span<const uint8_t>>(&part, 1));
}

Status writeFileAtomic(const std::filesystem::path& path, std::span<const std::span<const uint8_t>> parts) {
  std::filesystem::path tmp = path;
  tmp += ".tmp-" + std::to_string(::getpid());
  TempFileGuard guard(tmp.string()); // removed if a signal stops the process before the rename
  FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) return makeError(name(path), std::string("cannot create: ") + std::strerror(errno));
  bool written = true;
  for (std::span<const uint8_t> part : parts)
    if (written && !part.empty()) written = std::fwrite(part.data(), 1, part.size(), f) == part.size();
  int writeErrno = errno;
  bool closed = std::fclose(f) == 0;
  if (!written || !closed) {
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    return makeError(name(path), std::string("write failed: ") + std::strerror(written ? errno : writeErrno));
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    return makeError(name(path), "cannot rename temporary file into place: " + ec.message());
  }
  return Ok{};
}

Result<ImageRGBA8> readPng(const std::filesystem::path& path) {
  Result<std::vector<uint8_t>> bytes = readAll(path);
  if (!bytes) return bytes.error();
  if (bytes->size() > size_t(INT32_MAX)) return makeError(name(path), "file too large to decode");
  int w = 0, h = 0, comp = 0;
  stbi_uc* data = stbi_load_from_memory(bytes->data(), int(bytes->size()), &w, &h, &comp, 4);
  if (!data) {
    const char* reason = stbi_failure_reason();
    return makeError(name(path), std::string("cannot decode image: ") + (reason ? reason : "unknown format"));
  }
  ImageRGBA8 img;
  img.width = uint32_t(w);
  img.height = uint32_t(h);
  img.pixels.assign(data, data + size_t(w) * h * 4);
  stbi_image_free(data);
  return img;
}

Status writePng(const std::filesystem::path& path, const ImageRGBA8& image) {
  if (Status s = checkImage(path, image.width, image.height, image.pixels.size(), 4); !s) return s;
  std::vector<uint8_t> png;
  auto sink = [](void* context, void* data, int size) {
    auto* out = static_cast<std::vector<uint8_t>*>(context);
    out->insert(out->end(), static_cast<uint8_t*>(data), static_cast<uint8_t*>(data) + size);
  };
  if (!stbi_write_png_to_func(sink, &png, int(image.width), int(image.height), 4, image.pixels.data(),
                              int(image.width * 4)))
    return makeError(name(path), "PNG encoding failed");
  return writeFileAtomic(path, png.data(), png.size());
}

Status writeExr(const std::filesystem::path& path, const ImageF32& image) {
  if (Status s = checkImage(path, image.width, image.height, image.pixels.size(), 4); !s) return s;
  const int32_t w = int32_t(image.width), h = int32_t(image.height);
  std::vector<uint8_t> out;
  put<uint32_t>(out, kExrMagic);
  put<uint32_t>(out, 2); // version 2, no flags: single-part scanline file with short names

  std::vector<uint8_t> v;
  for (const char* ch : kExrChannels) {
    putString(v, ch);
    put<int32_t>(v, kExrFloat);
    put<uint8_t>(v, 0); // pLinear
    v.insert(v.end(), 3, 0);
    put<int32_t>(v, 1); // xSampling
    put<int32_t>(v, 1); // ySampling
  }
  v.push_back(0);
  putAttribute(out, "channels", "chlist", v);
  putAttribute(out, "compression", "compression", {0}); // NO_COMPRESSION
  v.clear();
  for (int32_t c : {0, 0, w - 1, h - 1}) put<int32_t>(v, c);
  putAttribute(out, "dataWindow", "box2i", v);
  putAttribute(out, "displayWindow", "box2i", v);
  putAttribute(out, "lineOrder", "lineOrder", {0}); // INCREASING_Y
  v.clear();
  put<float>(v, 1.0f);
  putAttribute(out, "pixelAspectRatio", "float", v);
  v.clear();
  put<float>(v, 0.0f);
  put<float>(v, 0.0f);
  putAttribute(out, "screenWindowCenter", "v2f", v);
  v.clear();
  put<float>(v, 1.0f);
  putAttribute(out, "screenWindowWidth", "float", v);
  out.push_back(0); // end of header

  // Offset table: uncompressed files hold one scanline per chunk; each chunk is
  // int32 y, int32 byte count, then each channel's row of floats in channel order.
  const uint64_t lineBytes = uint64_t(w) * 4 * sizeof(float);
  const uint64_t chunkBytes = 8 + lineBytes;
  const uint64_t tableEnd = out.size() + uint64_t(h) * 8;
  for (int32_t y = 0; y < h; ++y) put<uint64_t>(out, tableEnd + uint64_t(y) * chunkBytes);
  out.reserve(size_t(tableEnd + uint64_t(h) * chunkBytes));
  for (int32_t y = 0; y < h; ++y) {
    put<int32_t>(out, y);
    put<int32_t>(out, int32_t(lineBytes));
    const float* row = &image.pixels[size_t(y) * w * 4];
    for (int src : kExrSource)
      for (int32_t x = 0; x < w; ++x) put<float>(out, row[size_t(x) * 4 + src]);
  }
  return writeFileAtomic(path, out.data(), out.size());
}

Result<ImageF32> readExr(const std::filesystem::path& path) {
  Result<std::vector<uint8_t>> file = readAll(path);
  if (!file) return file.error();
  const std::vector<uint8_t>& b = *file;
  size_t pos = 0;
  bool truncated = false;
  auto get = [&]<class T>(T& value) {
    if (pos + sizeof(T) > b.size()) {
      truncated = true;
      value = T{};
      return;
    }
    std::memcpy(&value, &b[pos], sizeof(T));
    pos += sizeof(T);
  };
  auto getString = [&]() {
    std::string s;
    while (pos < b.size() && b[pos] != 0) s.push_back(char(b[pos++]));
    if (pos >= b.size()) truncated = true;
    ++pos;
    return s;
  };
  uint32_t magic = 0, version = 0;
  get(magic);
  get(version);
  if (truncated || magic != kExrMagic) return makeError(name(path), "not an OpenEXR file (bad magic number)");
  if ((version & 0xff) != 2 || (version & ~0xffu) != 0)
    return makeError(name(path), "unsupported OpenEXR variant (only single-part scanline version 2)");

  std::vector<std::string> channels;
  bool channelsOk = true, haveWindow = false;
  int32_t window[4] = {0, 0, -1, -1};
  int compression = -1;
  for (;;) {
    std::string attr = getString();
    if (truncated) return makeError(name(path), "truncated header");
    if (attr.empty()) break;
    std::string type = getString();
    int32_t size = 0;
    get(size);
    if (truncated || size < 0 || pos + size_t(size) > b.size()) return makeError(name(path), "truncated header");
    size_t end = pos + size_t(size);
    if (attr == "channels") {
      while (pos < end && b[pos] != 0) {
        std::string ch = getString();
        int32_t pixelType = 0, xs = 0, ys = 0;
        get(pixelType);
        pos += 4;
        get(xs);
        get(ys);
        channels.push_back(ch);
        channelsOk = channelsOk && pixelType == kExrFloat && xs == 1 && ys == 1;
      }
    } else if (attr == "compression" && size == 1) {
      compression = b[pos];
    } else if (attr == "dataWindow" && size == 16) {
      for (int32_t& c : window) get(c);
      haveWindow = true;
    }
    pos = end;
  }
  if (!channelsOk || channels != std::vector<std::string>{"A", "B", "G", "R"})
    return makeError(name(path), "unsupported channels (only FLOAT A,B,G,R)");
  if (compression != 0) return makeError(name(path), "unsupported compression (only NO_COMPRESSION)");
  if (!haveWindow || window[2] < window[0] || window[3] < window[1])
    return makeError(name(path), "missing or empty dataWindow");
  const int64_t w64 = int64_t(window[2]) - window[0] + 1, h64 = int64_t(window[3]) - window[1] + 1;
  if (w64 > 65536 || h64 > 65536) return makeError(name(path), "image too large");
  const int32_t w = int32_t(w64), h = int32_t(h64);

  ImageF32 img;
  img.width = uint32_t(w);
  img.height = uint32_t(h);
  img.pixels.assign(size_t(w) * h * 4, 0.0f);
  const size_t lineBytes = size_t(w) * 4 * sizeof(float);
  for (int32_t i = 0; i < h; ++i) {
    uint64_t offset = 0;
    get(offset);
    if (truncated || offset + 8 + lineBytes > b.size()) return makeError(name(path), "bad or truncated offset table");
    int32_t y = 0, bytes = 0;
    std::memcpy(&y, &b[offset], 4);
    std::memcpy(&bytes, &b[offset + 4], 4);
    y -= window[1];
    if (y < 0 || y >= h || size_t(bytes) != lineBytes) return makeError(name(path), "bad scanline chunk");
    const uint8_t* src = &b[offset + 8];
    float* row = &img.pixels[size_t(y) * w * 4];
    for (int c = 0; c < 4; ++c)
      for (int32_t x = 0; x < w; ++x)
        std::memcpy(&row[size_t(x) * 4 + kExrSource[c]], src + (size_t(c) * w + x) * 4, 4);
  }
  return img;
}

Status writePfm(const std::filesystem::path& path, const ImageF32& image) {
  if (Status s = checkImage(path, image.width, image.height, image.pixels.size(), 4); !s) return s;
  // A negative scale marks little-endian data.
  std::string header = "PF\n" + std::to_string(image.width) + " " + std::to_string(image.height) + "\n-1.0\n";
  std::vector<uint8_t> out(header.begin(), header.end());
  out.reserve(out.size() + size_t(image.width) * image.height * 12);
  for (uint32_t y = image.height; y-- > 0;) // PFM stores the bottom row first
    for (uint32_t x = 0; x < image.width; ++x)
      for (int c = 0; c < 3; ++c) put<float>(out, image.pixels[(size_t(y) * image.width + x) * 4 + c]);
  return writeFileAtomic(path, out.data(), out.size());
}

} // namespace mirage::io
