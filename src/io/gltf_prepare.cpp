#include "gltf_prepare.h"

#include <algorithm>
#include <cstring>
#include <optional>

#include <fmt/format.h>
#include <meshoptimizer.h>
#include <nlohmann/json.hpp>

#include "import_internal.h"

namespace mirage::io::detail {
namespace {

using json = nlohmann::json;
constexpr const char* kExt = "EXT_meshopt_compression";

uint32_t readU32(const char* p) {
  uint32_t v;
  std::memcpy(&v, p, 4);
  return v;
}

bool base64Decode(std::string_view in, std::vector<uint8_t>& out) {
  auto val = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    return -1;
  };
  uint32_t acc = 0;
  int bits = 0;
  for (char c : in) {
    if (c == '=') break;
    int v = val(c);
    if (v < 0) return false;
    acc = (acc << 6) | uint32_t(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(uint8_t((acc >> bits) & 0xff));
    }
  }
  return true;
}

int hexDigit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// A relative URI's %XX escapes decoded; a '%' not followed by two hex digits stays as it is.
std::string percentDecode(const std::string& s) {
  std::string out;
  for (size_t i = 0; i < s.size(); ++i) {
    int hi = s[i] == '%' && i + 2 < s.size() ? hexDigit(s[i + 1]) : -1, lo = hi >= 0 ? hexDigit(s[i + 2]) : -1;
    if (lo >= 0) {
      out.push_back(char(hi * 16 + lo));
      i += 2;
    } else {
      out.push_back(s[i]);
    }
  }
  return out;
}

// Bytes a base64 data URI decodes to, from its length alone.
uint64_t dataUriBytes(const std::string& uri) {
  size_t comma = uri.find(',');
  if (comma == std::string::npos) return 0;
  std::string_view payload = std::string_view(uri).substr(comma + 1);
  while (!payload.empty() && payload.back() == '=') payload.remove_suffix(1);
  return uint64_t(payload.size()) * 3 / 4;
}

// An unsigned integer property; `fallback` when absent, nullopt when present but not a non-negative integer (the
// glTF parser then reports the type error in its own words).
std::optional<uint64_t> uintProp(const json& o, const char* key, uint64_t fallback) {
  if (!o.contains(key)) return fallback;
  const json& v = o[key];
  if (v.is_number_unsigned()) return v.get<uint64_t>();
  if (v.is_number_integer() && v.get<int64_t>() >= 0) return uint64_t(v.get<int64_t>());
  if (v.is_number_float()) { // "36.0": JSON has one number type; integral values count
    double d = v.get<double>();
    if (d >= 0.0 && d < 9.2e18 && d == double(uint64_t(d))) return uint64_t(d);
  }
  return std::nullopt;
}

// Everything the glTF parser and its image decoder trust about buffer layout, checked first: they index buffers by
// bufferView ranges without bounds checks (an image bufferView past its buffer crashes the image decoder), read a
// directory named by a uri as a file, and skip missing images with a warning.
Status checkLayout(const json& doc, size_t binBytes, bool glb, const std::filesystem::path& baseDir, bool checkImages,
                   const std::string& file) {
  auto fail = [&](const std::string& problem) -> Status { return makeError(file, problem); };
  auto external = [&](const char* what, size_t i, const std::string& uri, uint64_t need) -> Status {
    std::filesystem::path p = baseDir / percentDecode(uri);
    if (std::string problem = inputFileProblem(p); !problem.empty())
      return fail(fmt::format("{} {} {}: {}", what, i, quoteInput(uri), problem));
    std::error_code ec;
    uint64_t size = std::filesystem::file_size(p, ec);
    if (!ec && size < need)
      return fail(
          fmt::format("{} {} {}: the file holds {} bytes, byteLength says {}", what, i, quoteInput(uri), size, need));
    return Ok{};
  };
  std::vector<uint64_t> bufferBytes;
  if (doc.contains("buffers") && doc["buffers"].is_array()) {
    const json& buffers = doc["buffers"];
    for (size_t i = 0; i < buffers.size(); ++i) {
      const json& b = buffers[i];
      // A length that is no integer: the parser rejects the file; meanwhile no view is checked against it.
      const std::optional<uint64_t> parsed = b.is_object() ? uintProp(b, "byteLength", 0) : std::nullopt;
      const uint64_t length = parsed.value_or(UINT64_MAX);
      bufferBytes.push_back(length);
      if (!parsed) continue;
      // A meshopt fallback buffer has a length and deliberately no data.
      const bool fallback = b.contains("extensions") && b["extensions"].is_object() && b["extensions"].contains(kExt) &&
                            b["extensions"][kExt].is_object() && b["extensions"][kExt].contains("fallback") &&
                            b["extensions"][kExt]["fallback"].is_boolean() &&
                            b["extensions"][kExt]["fallback"].get<bool>();
      if (b.contains("uri") && b["uri"].is_string()) {
        const std::string uri = b["uri"].get<std::string>();
        if (uri.rfind("data:", 0) == 0) {
          if (dataUriBytes(uri) < length)
            return fail(fmt::format("buffer {}: its data URI holds {} bytes, byteLength says {}", i, dataUriBytes(uri),
                                    length));
        } else if (Status s = external("buffer", i, uri, length); !s) {
          return s;
        }
      } else if (glb && i == 0 && !fallback && length > binBytes) {
        return fail(fmt::format("buffer 0: byteLength {} exceeds the GLB BIN chunk ({} bytes)", length, binBytes));
      }
    }
  }
  if (doc.contains("bufferViews") && doc["bufferViews"].is_array()) {
    const json& views = doc["bufferViews"];
    for (size_t v = 0; v < views.size(); ++v) {
      const json& view = views[v];
      if (!view.is_object()) continue;
      auto buffer = uintProp(view, "buffer", 0), offset = uintProp(view, "byteOffset", 0),
           length = uintProp(view, "byteLength", 0);
      if (!buffer || !offset || !length) continue;
      if (*buffer >= bufferBytes.size())
        return fail(fmt::format("bufferView {} refers to buffer {} ({} buffers)", v, *buffer, bufferBytes.size()));
      if (*offset > bufferBytes[*buffer] || *length > bufferBytes[*buffer] - *offset)
        return fail(fmt::format("bufferView {} (bytes {}..{}) runs past buffer {} ({} bytes)", v, *offset,
                                *offset + *length, *buffer, bufferBytes[*buffer]));
    }
  }
  if (checkImages && doc.contains("images") && doc["images"].is_array()) {
    const json& images = doc["images"];
    for (size_t i = 0; i < images.size(); ++i) {
      const json& img = images[i];
      if (!img.is_object() || !img.contains("uri") || !img["uri"].is_string()) continue;
      const std::string uri = img["uri"].get<std::string>();
      if (uri.rfind("data:", 0) != 0)
        if (Status s = external("image", i, uri, 0); !s) return s;
    }
  }
  return Ok{};
}

void align(std::vector<uint8_t>& v, size_t a) { v.resize((v.size() + a - 1) / a * a, 0); }

// The extension's constraints on one compressed view, checked before decoding: the decoders assert on them instead
// of returning an error. The message is the problem only (the caller names the file and view).
Status checkMeshoptView(const std::string& mode, const std::string& filter, size_t stride, size_t count) {
  auto bad = [](std::string problem) -> Status { return Error{std::move(problem)}; };
  if (mode == "ATTRIBUTES") {
    if (stride % 4 != 0) return bad(fmt::format("mode ATTRIBUTES needs a byteStride divisible by 4 (got {})", stride));
  } else if (mode == "TRIANGLES" || mode == "INDICES") {
    if (stride != 2 && stride != 4) return bad(fmt::format("mode {} needs byteStride 2 or 4 (got {})", mode, stride));
    if (mode == "TRIANGLES" && count % 3 != 0)
      return bad(fmt::format("mode TRIANGLES needs a count divisible by 3 (got {})", count));
  } else {
    return bad(fmt::format("has unknown mode {}", quoteInput(mode)));
  }
  if (filter == "NONE") return Ok{};
  if (mode != "ATTRIBUTES") return bad(fmt::format("filter {} needs mode ATTRIBUTES", quoteInput(filter)));
  if (filter == "OCTAHEDRAL" && stride != 4 && stride != 8)
    return bad(fmt::format("filter OCTAHEDRAL needs byteStride 4 or 8 (got {})", stride));
  if (filter == "QUATERNION" && stride != 8)
    return bad(fmt::format("filter QUATERNION needs byteStride 8 (got {})", stride));
  if (filter != "OCTAHEDRAL" && filter != "QUATERNION" && filter != "EXPONENTIAL")
    return bad(fmt::format("has unknown filter {}", quoteInput(filter)));
  return Ok{};
}

} // namespace

Result<std::optional<std::vector<uint8_t>>> prepareGltf(const std::vector<char>& bytes,
                                                        const std::filesystem::path& baseDir, bool checkImages,
                                                        const std::string& file) {
  if (bytes.empty()) return makeError(file, "empty file (0 bytes)");
  std::string_view jsonText(bytes.data(), bytes.size());
  std::string_view bin;
  const bool glb = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
  if (glb) {
    // 12-byte header, then chunks of (length, type, data); tinygltf reports other malformations itself.
    if (bytes.size() < 20)
      return makeError(
          file, fmt::format("truncated GLB: {} bytes, less than a header and one chunk header (20)", bytes.size()));
    uint32_t jsonLen = readU32(bytes.data() + 12);
    if (readU32(bytes.data() + 16) != 0x4E4F534A || 20 + uint64_t(jsonLen) > bytes.size())
      return std::optional<std::vector<uint8_t>>{};
    jsonText = std::string_view(bytes.data() + 20, jsonLen);
    size_t binAt = 20 + size_t(jsonLen);
    if (binAt + 8 <= bytes.size() && readU32(bytes.data() + binAt + 4) == 0x004E4942) {
      uint32_t binLen = readU32(bytes.data() + binAt);
      if (binAt + 8 + uint64_t(binLen) > bytes.size()) return makeError(file, "GLB BIN chunk is truncated");
      bin = std::string_view(bytes.data() + binAt + 8, binLen);
    }
  }
  json doc = json::parse(jsonText, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded() || !doc.is_object()) return std::optional<std::vector<uint8_t>>{};
  try { // every access is type-checked first; the guard keeps a missed case an Error, never a throw
    if (Status s = checkLayout(doc, bin.size(), glb, baseDir, checkImages, file); !s) return s.error();
  } catch (const std::exception& e) {
    return makeError(file, fmt::format("bad glTF layout: {}", escapeInput(e.what(), 160)));
  }
  auto usesExt = [&](const char* key) {
    if (!doc.contains(key) || !doc[key].is_array()) return false;
    for (const json& e : doc[key])
      if (e.is_string() && e.get<std::string>() == kExt) return true;
    return false;
  };
  if (!usesExt("extensionsUsed") && !usesExt("extensionsRequired")) return std::optional<std::vector<uint8_t>>{};

  try { // nlohmann's typed accessors throw on wrong JSON types; turn that into one Error line.
    // 1. The bytes of every buffer; fallback buffers (no uri, not the GLB chunk) stay empty.
    json& buffers = doc["buffers"];
    std::vector<std::vector<uint8_t>> data(buffers.size());
    std::vector<bool> present(buffers.size(), false);
    for (size_t i = 0; i < buffers.size(); ++i) {
      const json& b = buffers[i];
      size_t byteLength = b.value("byteLength", size_t(0));
      if (b.contains("uri")) {
        std::string uri = b["uri"].get<std::string>();
        if (uri.rfind("data:", 0) == 0) {
          size_t comma = uri.find(',');
          if (comma == std::string::npos || !base64Decode(std::string_view(uri).substr(comma + 1), data[i]))
            return makeError(file, fmt::format("buffer {} has a bad data URI", i));
        } else {
          auto ext = readFile(baseDir / percentDecode(uri));
          if (!ext) return makeError(file, fmt::format("buffer {}: cannot read {}", i, quoteInput(uri)));
          data[i].assign(ext->begin(), ext->end());
        }
        present[i] = true;
      } else if (glb && i == 0 && !bin.empty()) {
        data[i].assign(bin.begin(), bin.end());
        present[i] = true;
      }
      if (present[i] && data[i].size() < byteLength)
        return makeError(file, fmt::format("buffer {} is shorter than its byteLength", i));
    }

    // 2. One output buffer: the present buffers, then each decoded view.
    std::vector<uint8_t> out;
    std::vector<size_t> base(buffers.size(), 0);
    for (size_t i = 0; i < data.size(); ++i) {
      if (!present[i]) continue;
      align(out, 16);
      base[i] = out.size();
      out.insert(out.end(), data[i].begin(), data[i].end());
    }
    json& views = doc["bufferViews"];
    for (size_t v = 0; v < views.size(); ++v) {
      json& view = views[v];
      if (view.contains("extensions") && view["extensions"].contains(kExt)) {
        const json& ext = view["extensions"][kExt];
        size_t src = ext.at("buffer").get<size_t>();
        size_t off = ext.value("byteOffset", size_t(0)), len = ext.at("byteLength").get<size_t>();
        size_t stride = ext.at("byteStride").get<size_t>(), count = ext.at("count").get<size_t>();
        std::string mode = ext.at("mode").get<std::string>(), filter = ext.value("filter", std::string("NONE"));
        if (src >= data.size() || !present[src] || off > data[src].size() || len > data[src].size() - off)
          return makeError(file, fmt::format("bufferView {}: compressed data out of range", v));
        // The codecs expand at most ~64x (an all-zero vertex stream); larger claims are hostile or corrupt.
        if (stride == 0 || stride > 256 || count > (64 * len + (size_t(1) << 20)) / stride)
          return makeError(file, fmt::format("bufferView {}: bad meshopt stride/count", v));
        if (Status s = checkMeshoptView(mode, filter, stride, count); !s)
          return makeError(file, fmt::format("bufferView {}: EXT_meshopt_compression {}", v, s.error().message));
        align(out, 16);
        size_t at = out.size();
        out.resize(at + count * stride);
        const unsigned char* in = data[src].data() + off;
        int rc;
        if (mode == "ATTRIBUTES")
          rc = meshopt_decodeVertexBuffer(out.data() + at, count, stride, in, len);
        else if (mode == "TRIANGLES")
          rc = meshopt_decodeIndexBuffer(out.data() + at, count, stride, in, len);
        else if (mode == "INDICES")
          rc = meshopt_decodeIndexSequence(out.data() + at, count, stride, in, len);
        else
          return makeError(file, fmt::format("bufferView {}: unknown meshopt mode {}", v, quoteInput(mode)));
        if (rc != 0) return makeError(file, fmt::format("bufferView {}: meshopt decoding failed ({})", v, rc));
        if (filter == "OCTAHEDRAL")
          meshopt_decodeFilterOct(out.data() + at, count, stride);
        else if (filter == "QUATERNION")
          meshopt_decodeFilterQuat(out.data() + at, count, stride);
        else if (filter == "EXPONENTIAL")
          meshopt_decodeFilterExp(out.data() + at, count, stride);
        else if (filter != "NONE")
          return makeError(file, fmt::format("bufferView {}: unknown filter {}", v, quoteInput(filter)));
        view["buffer"] = 0;
        view["byteOffset"] = at;
        view["byteLength"] = count * stride;
        view["extensions"].erase(kExt);
        if (view["extensions"].empty()) view.erase("extensions");
      } else {
        size_t b = view.at("buffer").get<size_t>();
        if (b >= data.size() || !present[b])
          return makeError(file, fmt::format("bufferView {} refers to a buffer without data", v));
        view["buffer"] = 0;
        view["byteOffset"] = base[b] + view.value("byteOffset", size_t(0));
      }
    }
    align(out, 4);
    doc["buffers"] = json::array({json{{"byteLength", out.size()}}});
    for (const char* key : {"extensionsUsed", "extensionsRequired"}) {
      if (!doc.contains(key)) continue;
      json& arr = doc[key];
      arr.erase(std::remove(arr.begin(), arr.end(), json(kExt)), arr.end());
      if (arr.empty()) doc.erase(key);
    }

    // 3. Re-pack as GLB: header, JSON chunk (space padded), BIN chunk.
    std::string text = doc.dump();
    text.resize((text.size() + 3) / 4 * 4, ' ');
    std::vector<uint8_t> glbOut(12 + 8 + text.size() + 8 + out.size());
    auto put = [&](size_t at, uint32_t v) { std::memcpy(glbOut.data() + at, &v, 4); };
    std::memcpy(glbOut.data(), "glTF", 4);
    put(4, 2);
    put(8, uint32_t(glbOut.size()));
    put(12, uint32_t(text.size()));
    put(16, 0x4E4F534A);
    std::memcpy(glbOut.data() + 20, text.data(), text.size());
    size_t binAt = 20 + text.size();
    put(binAt, uint32_t(out.size()));
    put(binAt + 4, 0x004E4942);
    std::memcpy(glbOut.data() + binAt + 8, out.data(), out.size());
    return std::optional<std::vector<uint8_t>>(std::move(glbOut));
  } catch (const std::exception& e) {
    return makeError(file, fmt::format("bad EXT_meshopt_compression data: {}", escapeInput(e.what(), 160)));
  }
}

} // namespace mirage::io::detail
