#include "mirage/surfels/surfel_io.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <unistd.h>

#include <fmt/format.h>

#include "mirage/asset/container.h"

namespace mirage::surfels {

namespace {

constexpr uint32_t kChunkVersion = 2; // 2 added the mesh index; 1 is still read

struct SurfelChunkHeader {
  uint32_t version = kChunkVersion;
  uint32_t count = 0;
  uint32_t referenceCount = 0;
  uint32_t pad = 0;
  float boxMin[3];
  float boxMax[3];
  float referenceMeanSpacing = 0.0f;
  float referenceMedianSpacing = 0.0f;
};
static_assert(sizeof(SurfelChunkHeader) == 48, "SURF chunk header layout");

template <class T> void append(std::vector<uint8_t>& out, const T* data, size_t count) {
  // resize + memcpy rather than insert: GCC 12 warns falsely (-Wstringop-overflow) on the insert.
  size_t at = out.size(), bytes = count * sizeof(T);
  out.resize(at + bytes);
  if (bytes) std::memcpy(out.data() + at, data, bytes);
}

} // namespace

Status writeSurfelPly(const std::string& path, const SurfelCloud& c) {
  std::string header = "ply\nformat binary_little_endian 1.0\n"
                       "comment mirage surfels: progressive order; radius = Poisson radius of the prefix ending here\n";
  header += fmt::format("comment mirage_box {:.9g} {:.9g} {:.9g} {:.9g} {:.9g} {:.9g}\n", c.box.min.x, c.box.min.y,
                        c.box.min.z, c.box.max.x, c.box.max.y, c.box.max.z);
  header += fmt::format("comment mirage_reference {} {:.9g} {:.9g}\n", c.referenceCount, c.referenceMeanSpacing,
                        c.referenceMedianSpacing);
  header += fmt::format("element vertex {}\n", c.size());
  for (const char* p : {"x", "y", "z", "nx", "ny", "nz"}) header += fmt::format("property float {}\n", p);
  for (const char* p : {"red", "green", "blue", "alpha"}) header += fmt::format("property uchar {}\n", p);
  header += "property float radius\nend_header\n";
  std::vector<uint8_t> body;
  body.reserve(c.size() * 32);
  for (size_t i = 0; i < c.size(); ++i) {
    glm::vec3 p = surfelPosition(c.box, c.surfels[i]), n = surfelNormal(c.surfels[i]);
    float f[6] = {p.x, p.y, p.z, n.x, n.y, n.z};
    append(body, f, 6);
    append(body, &c.surfels[i].color, 1); // RGBA8 with R in the low byte is red green blue alpha
    float r = i < c.radii.size() ? c.radii[i] : 0.0f;
    append(body, &r, 1);
  }
  std::string tmp = fmt::format("{}.tmp-{}", path, getpid());
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    f.write(header.data(), std::streamsize(header.size()));
    f.write(reinterpret_cast<const char*>(body.data()), std::streamsize(body.size()));
    if (!f) {
      std::filesystem::remove(tmp);
      return makeError(path, "cannot write the file");
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp);
    return makeError(path, "cannot write the file: " + ec.message());
  }
  return Ok{};
}

Result<SurfelCloud> readSurfelPly(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return makeError(path, "cannot open the file");
  std::string line;
  if (!std::getline(f, line) || line != "ply") return makeError(path, "not a PLY file");
  struct Property {
    std::string name;
    bool isFloat;
  };
  std::vector<Property> props;
  size_t count = 0;
  bool haveBox = false, inVertex = false;
  SurfelCloud c;
  while (std::getline(f, line)) {
    std::istringstream s(line);
    std::string word;
    s >> word;
    if (word == "end_header") break;
    if (word == "format") {
      std::string fmtName;
      s >> fmtName;
      if (fmtName != "binary_little_endian") return makeError(path, "only binary_little_endian PLY is supported");
    } else if (word == "comment") {
      std::string key;
      s >> key;
      if (key == "mirage_box") {
        s >> c.box.min.x >> c.box.min.y >> c.box.min.z >> c.box.max.x >> c.box.max.y >> c.box.max.z;
        haveBox = bool(s);
      } else if (key == "mirage_reference") {
        s >> c.referenceCount >> c.referenceMeanSpacing >> c.referenceMedianSpacing;
      }
    } else if (word == "element") {
      std::string name;
      s >> name >> count;
      if (name != "vertex") return makeError(path, "unexpected element '" + name + "' in a surfel PLY");
      inVertex = true;
    } else if (word == "property") {
      std::string type, name;
      s >> type >> name;
      if (!inVertex || type == "list") return makeError(path, "unexpected property '" + name + "'");
      bool isFloat = type == "float" || type == "float32";
      if (!isFloat && type != "uchar" && type != "uint8")
        return makeError(path, "property '" + name + "' has unsupported type " + type);
      props.push_back({name, isFloat});
    }
  }
  if (!f) return makeError(path, "truncated PLY header");
  size_t stride = 0;
  int px = -1, py = -1, pz = -1;
  for (size_t i = 0; i < props.size(); ++i) {
    if (props[i].name == "x") px = int(i);
    if (props[i].name == "y") py = int(i);
    if (props[i].name == "z") pz = int(i);
    stride += props[i].isFloat ? 4 : 1;
  }
  if (px < 0 || py < 0 || pz < 0 || !props[px].isFloat || !props[py].isFloat || !props[pz].isFloat)
    return makeError(path, "PLY vertices need float x, y and z");
  std::vector<uint8_t> body(count * stride);
  f.read(reinterpret_cast<char*>(body.data()), std::streamsize(body.size()));
  if (size_t(f.gcount()) != body.size())
    return makeError(path, fmt::format("truncated: {} vertices need {} bytes", count, body.size()));

  std::vector<glm::vec3> positions(count), normals(count, glm::vec3(0, 0, 1));
  std::vector<uint32_t> colors(count, 0xffffffffu);
  c.radii.assign(count, 0.0f);
  for (size_t v = 0; v < count; ++v) {
    const uint8_t* rec = body.data() + v * stride;
    for (const Property& p : props) {
      float value = 0.0f;
      uint8_t byte = 0;
      if (p.isFloat)
        std::memcpy(&value, rec, 4);
      else
        byte = *rec;
      rec += p.isFloat ? 4 : 1;
      const std::string& n = p.name;
      if (n == "x" || n == "y" || n == "z")
        positions[v][n[0] - 'x'] = value;
      else if (n == "nx" || n == "ny" || n == "nz")
        normals[v][n[1] - 'x'] = value;
      else if (n == "radius")
        c.radii[v] = value;
      else if (!p.isFloat && (n == "red" || n == "green" || n == "blue" || n == "alpha")) {
        int shift = n == "red" ? 0 : n == "green" ? 8 : n == "blue" ? 16 : 24;
        colors[v] = (colors[v] & ~(0xffu << shift)) | uint32_t(byte) << shift;
      }
    }
  }
  if (!haveBox)
    for (glm::vec3 p : positions) c.box.add(p);
  c.surfels.reserve(count);
  for (size_t v = 0; v < count; ++v) c.surfels.push_back(packSurfel(c.box, positions[v], normals[v], colors[v]));
  return c;
}

std::vector<uint8_t> encodeSurfelChunk(const SurfelCloud& c, uint32_t mesh) {
  SurfelChunkHeader h;
  h.count = uint32_t(c.size());
  h.referenceCount = c.referenceCount;
  for (int a = 0; a < 3; ++a) h.boxMin[a] = c.box.min[a], h.boxMax[a] = c.box.max[a];
  h.referenceMeanSpacing = c.referenceMeanSpacing;
  h.referenceMedianSpacing = c.referenceMedianSpacing;
  std::vector<uint8_t> out;
  append(out, &h, 1);
  const uint32_t meshWords[2] = {mesh, 0};
  append(out, meshWords, 2);
  append(out, c.surfels.data(), c.size());
  std::vector<float> radii = c.radii;
  radii.resize(c.size(), 0.0f);
  append(out, radii.data(), radii.size());
  return out;
}

Result<MeshSurfels> decodeSurfelChunkWithMesh(std::span<const uint8_t> bytes, const std::string& file) {
  SurfelChunkHeader h;
  if (bytes.size() < sizeof(h)) return makeError(file, "SURF chunk is shorter than its header");
  std::memcpy(&h, bytes.data(), sizeof(h));
  if (h.version != 1 && h.version != kChunkVersion)
    return makeError(file, fmt::format("SURF chunk version {} is not supported", h.version));
  size_t headerBytes = sizeof(h) + (h.version >= 2 ? 8 : 0);
  size_t expected = headerBytes + size_t(h.count) * (sizeof(Surfel) + sizeof(float));
  if (bytes.size() != expected)
    return makeError(file, fmt::format("SURF chunk has {} bytes, {} surfels need {}", bytes.size(), h.count, expected));
  // Positions dequantize inside the box and renderers size discs by the radii: NaN or an infinite box
  // would reach the GPU as NaN geometry.
  bool finiteBox = true;
  for (int i = 0; i < 3; ++i) finiteBox = finiteBox && std::isfinite(h.boxMin[i]) && std::isfinite(h.boxMax[i]);
  if (!finiteBox) return makeError(file, "SURF chunk has a non-finite quantization box");
  if (std::isnan(h.referenceMeanSpacing) || std::isnan(h.referenceMedianSpacing))
    return makeError(file, "SURF chunk has a NaN reference spacing");
  MeshSurfels out;
  if (h.version >= 2) std::memcpy(&out.mesh, bytes.data() + sizeof(h), 4);
  SurfelCloud& c = out.cloud;
  c.box.min = {h.boxMin[0], h.boxMin[1], h.boxMin[2]};
  c.box.max = {h.boxMax[0], h.boxMax[1], h.boxMax[2]};
  c.referenceCount = h.referenceCount;
  c.referenceMeanSpacing = h.referenceMeanSpacing;
  c.referenceMedianSpacing = h.referenceMedianSpacing;
  c.surfels.resize(h.count);
  c.radii.resize(h.count);
  if (h.count == 0) return out; // memcpy from an empty vector's null data() is undefined, even for 0 bytes
  std::memcpy(c.surfels.data(), bytes.data() + headerBytes, h.count * sizeof(Surfel));
  std::memcpy(c.radii.data(), bytes.data() + headerBytes + h.count * sizeof(Surfel), h.count * sizeof(float));
  for (float r : c.radii)
    if (!(r >= 0.0f)) return makeError(file, "SURF chunk has a negative or NaN radius");
  return out;
}

Result<SurfelCloud> decodeSurfelChunk(std::span<const uint8_t> bytes, const std::string& file) {
  auto r = decodeSurfelChunkWithMesh(bytes, file);
  if (!r) return r.error();
  return std::move(r->cloud);
}

Status writeSurfelMrg(const std::string& path, const SurfelCloud& cloud) {
  asset::AssetWriter writer;
  writer.addChunk(asset::chunk::Surfels, encodeSurfelChunk(cloud));
  return writer.write(path);
}

Status writeSurfelMrg(const std::string& path, std::span<const MeshSurfels> clouds) {
  asset::AssetWriter writer;
  for (const MeshSurfels& m : clouds) writer.addChunk(asset::chunk::Surfels, encodeSurfelChunk(m.cloud, m.mesh));
  return writer.write(path);
}

Result<std::vector<MeshSurfels>> readSurfelMrgAll(const std::string& path) {
  auto reader = asset::AssetReader::open(path);
  if (!reader) return reader.error();
  std::vector<MeshSurfels> out;
  for (size_t i = 0; i < reader->chunks().size(); ++i) {
    if (reader->chunks()[i].type != asset::chunk::Surfels) continue;
    auto bytes = reader->readChunk(i);
    if (!bytes) return bytes.error();
    auto m = decodeSurfelChunkWithMesh(*bytes, path);
    if (!m) return m.error();
    out.push_back(std::move(*m));
  }
  if (out.empty()) return makeError(path, "no SURF chunk");
  return out;
}

Result<SurfelCloud> readSurfelMrg(const std::string& path) {
  auto all = readSurfelMrgAll(path);
  if (!all) return all.error();
  if (all->size() != 1)
    return makeError(
        path, fmt::format("holds {} surfel clouds (one per mesh); read them with readSurfelMrgAll", all->size()));
  return std::move(all->front().cloud);
}

} // namespace mirage::surfels
