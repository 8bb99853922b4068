#include "gltf_meshopt.h"

#include <algorithm>
#include <cstring>

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

std::string percentDecode(const std::string& s) {
  std::string out;
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%' && i + 2 < s.size()) {
      out.push_back(char(std::stoi(s.substr(i + 1, 2), nullptr, 16)));
      i += 2;
    } else {
      out.push_back(s[i]);
    }
  }
  return out;
}

void align(std::vector<uint8_t>& v, size_t a) { v.resize((v.size() + a - 1) / a * a, 0); }

} // namespace

Result<std::optional<std::vector<uint8_t>>>
decodeMeshoptGltf(const std::vector<char>& bytes, const std::filesystem::path& baseDir, const std::string& file) {
  std::string_view jsonText(bytes.data(), bytes.size());
  std::string_view bin;
  const bool glb = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
  if (glb) {
    // 12-byte header, then chunks of (length, type, data); tinygltf reports malformed files itself.
    if (bytes.size() < 20) return std::optional<std::vector<uint8_t>>{};
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
          if (!ext) return makeError(file, fmt::format("buffer {}: cannot read '{}'", i, uri));
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
        if (src >= data.size() || !present[src] || off + len > data[src].size())
          return makeError(file, fmt::format("bufferView {}: compressed data out of range", v));
        // The codecs expand at most ~64x (an all-zero vertex stream); larger claims are hostile or corrupt.
        if (stride == 0 || stride > 256 || count > (64 * len + (size_t(1) << 20)) / stride)
          return makeError(file, fmt::format("bufferView {}: bad meshopt stride/count", v));
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
          return makeError(file, fmt::format("bufferView {}: unknown meshopt mode '{}'", v, mode));
        if (rc != 0) return makeError(file, fmt::format("bufferView {}: meshopt decoding failed ({})", v, rc));
        if (filter == "OCTAHEDRAL")
          meshopt_decodeFilterOct(out.data() + at, count, stride);
        else if (filter == "QUATERNION")
          meshopt_decodeFilterQuat(out.data() + at, count, stride);
        else if (filter == "EXPONENTIAL")
          meshopt_decodeFilterExp(out.data() + at, count, stride);
        else if (filter != "NONE")
          return makeError(file, fmt::format("bufferView {}: unknown filter '{}'", v, filter));
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
    return makeError(file, fmt::format("bad EXT_meshopt_compression data: {}", e.what()));
  }
}

} // namespace mirage::io::detail
