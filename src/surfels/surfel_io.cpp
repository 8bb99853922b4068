#include "mirage/surfels/surfel_io.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <unistd.h>

#include <fmt/format.h>

#include "mirage/core/temp_files.h"
#include "mirage/core/input_text.h"

namespace mirage::surfels {

namespace {

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
  TempFileGuard guard(tmp); // removed if a signal stops the process before the rename
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

bool isSurfelPly(const std::string& path) {
  if (!inputFileProblem(path).empty()) return false; // never open a FIFO (it waits for a writer)
  std::ifstream f(path, std::ios::binary);
  std::string line;
  if (!std::getline(f, line) || line != "ply") return false;
  // The header is a few hundred bytes; a bounded read never scans a large binary body.
  for (int lines = 0; lines < 256 && std::getline(f, line) && line != "end_header"; ++lines)
    if (line.starts_with("comment mirage surfels")) return true;
  return false;
}

Result<SurfelCloud> readSurfelPly(const std::string& path) {
  if (std::string problem = inputFileProblem(path); !problem.empty()) return makeError(path, problem);
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
  // The count is checked against the bytes there before anything is allocated for it.
  std::streamoff start = f.tellg();
  f.seekg(0, std::ios::end);
  uint64_t available = uint64_t(f.tellg() - start);
  f.seekg(start);
  if (count > available / std::max<size_t>(stride, 1) || uint64_t(count) * stride != available)
    return makeError(path,
                     fmt::format("{}: element vertex count {} needs {} bytes of {}-byte vertices, the file has {}",
                                 count > available / std::max<size_t>(stride, 1) || uint64_t(count) * stride > available
                                     ? "truncated"
                                     : "trailing bytes",
                                 count, uint64_t(count) * stride, stride, available));
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
  auto finite = [](glm::vec3 p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); };
  for (size_t v = 0; v < count; ++v)
    if (!finite(positions[v]) || !finite(normals[v]) || !std::isfinite(c.radii[v]) || c.radii[v] < 0.0f)
      return makeError(path, fmt::format("vertex {} has a NaN or infinite position, normal or radius", v));
  if (!haveBox)
    for (glm::vec3 p : positions) c.box.add(p);
  for (int a = 0; a < 3; ++a)
    if (!std::isfinite(c.box.min[a]) || !std::isfinite(c.box.max[a]))
      return makeError(path, "mirage_box comment is NaN or infinite");
  c.surfels.reserve(count);
  for (size_t v = 0; v < count; ++v) c.surfels.push_back(packSurfel(c.box, positions[v], normals[v], colors[v]));
  return c;
}

} // namespace mirage::surfels
