// PLY import: ascii and binary (little/big endian), streamed through ChunkReader. The common binary layouts
// (float xyz[+normals][+uchar colours], faces as uchar count + int indices) take fast paths that copy straight
// from the read buffer; everything else goes through a generic per-property reader. Triangles come from `face`
// (polygons, fan-triangulated) and `tristrips` (strips with -1 restarts) elements. The data must match the header
// exactly: short data and bytes after the last element are both errors naming the element and both counts.
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <sstream>

#include <fmt/format.h>

#include "chunk_reader.h"
#include "import_internal.h"

namespace mirage::io {
namespace {

using detail::ChunkReader;

enum class Type : uint8_t { I8, U8, I16, U16, I32, U32, F32, F64, Invalid };

Type parseType(const std::string& s) {
  if (s == "char" || s == "int8") return Type::I8;
  if (s == "uchar" || s == "uint8") return Type::U8;
  if (s == "short" || s == "int16") return Type::I16;
  if (s == "ushort" || s == "uint16") return Type::U16;
  if (s == "int" || s == "int32") return Type::I32;
  if (s == "uint" || s == "uint32") return Type::U32;
  if (s == "float" || s == "float32") return Type::F32;
  if (s == "double" || s == "float64") return Type::F64;
  return Type::Invalid;
}

size_t typeSize(Type t) {
  static constexpr size_t sizes[] = {1, 1, 2, 2, 4, 4, 4, 8, 0};
  return sizes[size_t(t)];
}

struct Property {
  std::string name;
  Type type = Type::Invalid;      // value type (list items for lists)
  Type countType = Type::Invalid; // list count type; Invalid for scalars
  bool isList() const { return countType != Type::Invalid; }
};

struct Element {
  std::string name;
  uint64_t count = 0;
  std::vector<Property> props;
  bool fixedSize() const {
    for (const Property& p : props)
      if (p.isList()) return false;
    return true;
  }
  size_t recordSize() const {
    size_t s = 0;
    for (const Property& p : props) s += typeSize(p.type);
    return s;
  }
  int find(std::initializer_list<const char*> names) const {
    for (size_t i = 0; i < props.size(); ++i)
      for (const char* n : names)
        if (props[i].name == n) return int(i);
    return -1;
  }
};

template <class T> T load(const unsigned char* b) {
  T v;
  std::memcpy(&v, b, sizeof v);
  return v;
}

// Read one binary scalar, byte-swapping for the other endianness.
double loadScalar(const char* p, Type t, bool swap) {
  unsigned char b[8];
  size_t n = typeSize(t);
  std::memcpy(b, p, n);
  if (swap)
    for (size_t i = 0; i < n / 2; ++i) std::swap(b[i], b[n - 1 - i]);
  switch (t) {
  case Type::I8:
    return double(int8_t(b[0]));
  case Type::U8:
    return double(b[0]);
  case Type::I16:
    return load<int16_t>(b);
  case Type::U16:
    return load<uint16_t>(b);
  case Type::I32:
    return load<int32_t>(b);
  case Type::U32:
    return load<uint32_t>(b);
  case Type::F32:
    return load<float>(b);
  case Type::F64:
    return load<double>(b);
  default:
    return 0.0;
  }
}

// A strip's restart marker (-1 in the file).
constexpr uint32_t kRestart = 0xffffffffu;

// Integer list entries must convert exactly; -1 becomes kRestart, anything else negative or too large an index past
// any vertex array (validateMesh reports it; a face with -1 is reported the same way).
uint32_t toIndex(double v) {
  if (v == -1.0) return kRestart;
  return (v >= 0.0 && v < 4294967295.0) ? uint32_t(v) : 0xfffffffeu;
}

float srgbToLinear(float c) { return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f); }

class PlyParser {
public:
  PlyParser(std::string file, const ImportOptions& options) : file_(std::move(file)), options_(options) {}

  Result<Scene> run(const std::filesystem::path& path) {
    if (std::string problem = inputFileProblem(path); !problem.empty()) return makeError(file_, problem);
    if (!in_.open(path)) return makeError(file_, "cannot open file");
    std::error_code ec;
    fileSize_ = std::filesystem::file_size(path, ec);
    if (Status s = parseHeader(); !s) return s.error();
    for (size_t i = 0; i < 256; ++i) colorLut_[i] = srgbToLinear(float(i) / 255.0f);
    for (const Element& e : elements_) {
      Status s = ascii_ ? readAscii(e) : readBinary(e);
      if (!s) return s.error();
    }
    if (Status s = checkEnd(); !s) return s.error();
    if (mesh_.positions.empty() && !faceSeen_) return makeError(file_, "no vertex element");
    Scene scene;
    mesh_.name = std::filesystem::path(file_).stem().string();
    scene.meshes.push_back(std::move(mesh_));
    if (Status s = detail::finalizeScene(scene, file_, options_); !s) return s.error();
    return scene;
  }

private:
  Status fail(const std::string& problem) const { return makeError(file_, problem); }

  Status parseHeader() {
    // The header is text ending in "end_header": the first buffer (the whole file, or 16 MiB) is
    // far more than any real header.
    in_.fill();
    std::string_view all(in_.data(), in_.available());
    if (all.substr(0, 3) != "ply") return fail("not a PLY file (missing 'ply' magic)");
    size_t endPos = all.find("end_header");
    if (endPos == std::string_view::npos) return fail("PLY header has no end_header");
    size_t bodyStart = all.find('\n', endPos);
    if (bodyStart == std::string_view::npos) return fail("PLY header has no end_header line end");
    std::istringstream header{std::string(all.substr(0, endPos))};
    in_.consume(bodyStart + 1);

    std::string line;
    bool haveFormat = false;
    while (std::getline(header, line)) {
      std::istringstream ls(line);
      std::string kw;
      ls >> kw;
      if (kw == "format") {
        std::string fmtName;
        ls >> fmtName;
        if (fmtName == "ascii")
          ascii_ = true;
        else if (fmtName == "binary_little_endian")
          swap_ = std::endian::native != std::endian::little;
        else if (fmtName == "binary_big_endian")
          swap_ = std::endian::native != std::endian::big;
        else
          return fail(fmt::format("unknown PLY format {}", quoteInput(fmtName)));
        haveFormat = true;
      } else if (kw == "element") {
        Element e;
        if (!(ls >> e.name >> e.count)) return fail("bad PLY element line " + quoteInput(line));
        // One element of each name: a second 'vertex' element would be read with the first one's
        // attribute arrays (a uv array sized by it, a layout without uv: out-of-bounds reads).
        for (const Element& other : elements_)
          if (other.name == e.name) return fail(fmt::format("PLY element {} declared twice", quoteInput(e.name)));
        elements_.push_back(std::move(e));
      } else if (kw == "property") {
        if (elements_.empty()) return fail("PLY property before any element");
        Property p;
        std::string t;
        ls >> t;
        if (t == "list") {
          std::string ct, it;
          ls >> ct >> it >> p.name;
          p.countType = parseType(ct);
          p.type = parseType(it);
          if (p.countType == Type::Invalid || p.countType == Type::F32 || p.countType == Type::F64)
            return fail("bad PLY list count type in " + quoteInput(line));
        } else {
          p.type = parseType(t);
          ls >> p.name;
        }
        if (p.type == Type::Invalid || p.name.empty()) return fail("bad PLY property line " + quoteInput(line));
        elements_.back().props.push_back(std::move(p));
      }
      // comment, obj_info and unknown keywords carry nothing we need.
    }
    if (!haveFormat) return fail("PLY header has no format line");
    // Counts come from an untrusted header: reject ones the file cannot hold before sizing arrays by them
    // (every binary record takes its fixed bytes or at least a list count; every ascii value at least 2 chars).
    uint64_t minBytes = 0;
    for (const Element& e : elements_) {
      uint64_t per = 0;
      for (const Property& p : e.props) per += p.isList() ? typeSize(p.countType) : typeSize(p.type);
      if (ascii_) per = 2 * e.props.size();
      if ((per > 0 && e.count > fileSize_ / per) || (per == 0 && e.count > fileSize_))
        return fail(fmt::format("file truncated: element {} declares {} records, more than the file's {} bytes hold",
                                quoteInput(e.name), e.count, fileSize_));
      minBytes += e.count * per;
    }
    if (minBytes > fileSize_) return fail("file truncated: shorter than its header declares");
    return Ok{};
  }

  // Indices of the vertex properties we keep.
  struct VertexLayout {
    int x, y, z, nx, ny, nz, r, g, b, a, u, v;
  };
  VertexLayout vertexLayout(const Element& e) const {
    return {e.find({"x"}),
            e.find({"y"}),
            e.find({"z"}),
            e.find({"nx"}),
            e.find({"ny"}),
            e.find({"nz"}),
            e.find({"red", "diffuse_red", "r"}),
            e.find({"green", "diffuse_green", "g"}),
            e.find({"blue", "diffuse_blue", "b"}),
            e.find({"alpha", "diffuse_alpha"}),
            e.find({"u", "s", "texture_u", "texture_s"}),
            e.find({"v", "t", "texture_v", "texture_t"})};
  }

  void beginVertices(const Element& e, const VertexLayout& L) {
    size_t n = size_t(e.count);
    mesh_.positions.resize(n);
    if (L.nx >= 0 && L.ny >= 0 && L.nz >= 0) mesh_.normals.resize(n);
    if (L.r >= 0 && L.g >= 0 && L.b >= 0) mesh_.colors.resize(n);
    if (L.u >= 0 && L.v >= 0) mesh_.uv0.resize(n);
  }

  float colorValue(double v, Type t) const {
    // Integer colours are 8-bit sRGB in practice; Scene colours are linear.
    if (t == Type::U8) return colorLut_[size_t(v) & 255];
    if (t == Type::F32 || t == Type::F64) return float(v);
    return srgbToLinear(float(v) / 255.0f);
  }

  // Store one vertex from its property values.
  void storeVertex(size_t i, const Element& e, const VertexLayout& L, const double* vals) {
    mesh_.positions[i] = glm::vec3(vals[L.x], vals[L.y], vals[L.z]);
    if (!mesh_.normals.empty()) mesh_.normals[i] = glm::vec3(vals[L.nx], vals[L.ny], vals[L.nz]);
    if (!mesh_.colors.empty()) {
      float alpha = 1.0f;
      if (L.a >= 0) alpha = e.props[L.a].type == Type::U8 ? float(vals[L.a] / 255.0) : float(vals[L.a]);
      mesh_.colors[i] = glm::vec4(colorValue(vals[L.r], e.props[L.r].type), colorValue(vals[L.g], e.props[L.g].type),
                                  colorValue(vals[L.b], e.props[L.b].type), alpha);
    }
    if (!mesh_.uv0.empty()) mesh_.uv0[i] = glm::vec2(vals[L.u], vals[L.v]);
  }

  // Append a polygon, fan-triangulated.
  Status addPolygon(const uint32_t* idx, size_t n, uint64_t face) {
    if (n < 3) return fail(fmt::format("face {} has {} vertices (need at least 3)", face, n));
    for (size_t k = 1; k + 1 < n; ++k) {
      mesh_.indices.push_back(idx[0]);
      mesh_.indices.push_back(idx[k]);
      mesh_.indices.push_back(idx[k + 1]);
    }
    return Ok{};
  }

  // Append a triangle strip: -1 restarts; every other triangle is flipped to keep one winding; triangles with a
  // repeated index are the zero-area stitches strippers insert between runs and carry no surface, so they are dropped.
  void addStrip(const uint32_t* idx, size_t n) {
    size_t start = 0; // first index of the current run
    for (size_t i = 0; i < n; ++i) {
      if (idx[i] == kRestart) {
        start = i + 1;
        continue;
      }
      if (i < start + 2) continue;
      uint32_t a = idx[i - 2], b = idx[i - 1], c = idx[i];
      if ((i - start) % 2 == 1) std::swap(a, b);
      if (a == b || b == c || a == c) continue;
      mesh_.indices.insert(mesh_.indices.end(), {a, b, c});
    }
  }

  Status truncated(const Element& e, uint64_t got) const {
    return fail(fmt::format("file truncated: element {} declares {} records, the data holds {}", quoteInput(e.name),
                            e.count, got));
  }

  // Element kinds that carry triangles, and their index list (both property names occur in the wild).
  bool isVertex(const Element& e) const { return e.name == "vertex"; }
  bool isFace(const Element& e) const { return e.name == "face"; }
  bool isStrips(const Element& e) const { return e.name == "tristrips"; }
  int faceListProp(const Element& e) const {
    int i = e.find({"vertex_indices", "vertex_index"});
    return (i >= 0 && e.props[i].isList()) ? i : -1;
  }

  Status checkEnd();
  bool skipRecord(const Element& e);
  Status readBinary(const Element& e);
  Status readBinaryFastVertices(const Element& e, const VertexLayout& L);
  Status readBinaryFastFaces(const Element& e);
  Status readAscii(const Element& e);

  std::string file_;
  ImportOptions options_;
  ChunkReader in_;
  std::vector<Element> elements_;
  bool ascii_ = false;
  bool swap_ = false;
  bool faceSeen_ = false;
  uint64_t fileSize_ = 0;
  Mesh mesh_;
  float colorLut_[256];
};

Status PlyParser::readBinary(const Element& e) {
  const bool vertex = isVertex(e);
  const bool face = isFace(e);
  VertexLayout L{};
  if (vertex) {
    L = vertexLayout(e);
    if (L.x < 0 || L.y < 0 || L.z < 0) return fail("PLY vertex element lacks x, y or z");
    beginVertices(e, L);
    if (e.fixedSize() && !swap_) return readBinaryFastVertices(e, L);
  }
  const bool strips = isStrips(e);
  int listProp = face || strips ? faceListProp(e) : -1;
  if (face || strips) {
    if (listProp < 0) return fail(fmt::format("PLY {} element has no vertex_indices list", quoteInput(e.name)));
    faceSeen_ = true;
    const Property& lp = e.props[listProp];
    if (face && e.props.size() == 1 && lp.countType == Type::U8 && (lp.type == Type::I32 || lp.type == Type::U32) &&
        !swap_) {
      mesh_.indices.reserve(size_t(e.count) * 3);
      return readBinaryFastFaces(e);
    }
  }
  if (!vertex && !face && !strips && e.fixedSize()) { // skip unknown fixed-size elements wholesale
    uint64_t left = e.count * e.recordSize();
    while (left > 0) {
      size_t step = size_t(std::min<uint64_t>(left, in_.capacity()));
      if (!in_.ensure(step)) return fail(fmt::format("file truncated inside element {}", quoteInput(e.name)));
      in_.consume(step);
      left -= step;
    }
    return Ok{};
  }
  // Generic path: property by property.
  std::vector<double> vals(e.props.size());
  std::vector<uint32_t> poly;
  for (uint64_t r = 0; r < e.count; ++r) {
    for (size_t pi = 0; pi < e.props.size(); ++pi) {
      const Property& p = e.props[pi];
      if (!p.isList()) {
        size_t s = typeSize(p.type);
        if (!in_.ensure(s)) return truncated(e, r);
        vals[pi] = loadScalar(in_.data(), p.type, swap_);
        in_.consume(s);
        continue;
      }
      size_t cs = typeSize(p.countType);
      if (!in_.ensure(cs)) return truncated(e, r);
      double cnt = loadScalar(in_.data(), p.countType, swap_);
      in_.consume(cs);
      if (cnt < 0) return fail(fmt::format("element {} record {} has a negative list length", quoteInput(e.name), r));
      size_t n = size_t(cnt), s = typeSize(p.type);
      if (n * s > fileSize_) return truncated(e, r); // a list longer than the whole file
      if (!in_.ensure(n * s)) return truncated(e, r);
      if (int(pi) == listProp) {
        poly.resize(n);
        for (size_t k = 0; k < n; ++k) poly[k] = toIndex(loadScalar(in_.data() + k * s, p.type, swap_));
      }
      in_.consume(n * s);
    }
    if (vertex) storeVertex(size_t(r), e, L, vals.data());
    if (face)
      if (Status st = addPolygon(poly.data(), poly.size(), r); !st) return st;
    if (strips) addStrip(poly.data(), poly.size());
  }
  return Ok{};
}

Status PlyParser::readBinaryFastVertices(const Element& e, const VertexLayout& L) {
  const size_t rec = e.recordSize();
  std::vector<size_t> offset(e.props.size());
  for (size_t i = 0, o = 0; i < e.props.size(); ++i) {
    offset[i] = o;
    o += typeSize(e.props[i].type);
  }
  auto contiguousF32 = [&](int a, int b, int c) {
    return a >= 0 && b >= 0 && c >= 0 && e.props[a].type == Type::F32 && e.props[b].type == Type::F32 &&
           e.props[c].type == Type::F32 && offset[b] == offset[a] + 4 && offset[c] == offset[a] + 8;
  };
  const bool fastPos = contiguousF32(L.x, L.y, L.z);
  const bool fastNrm = mesh_.normals.empty() || contiguousF32(L.nx, L.ny, L.nz);
  std::vector<double> vals(e.props.size());
  size_t done = 0;
  const size_t total = size_t(e.count);
  while (done < total) {
    size_t batch = std::min(total - done, std::max<size_t>(1, in_.capacity() / rec));
    if (!in_.ensure(batch * rec)) return truncated(e, done + in_.available() / rec);
    const char* base = in_.data();
    if (fastPos && fastNrm && mesh_.colors.empty() && mesh_.uv0.empty()) {
      // The hot loop for scans: straight copies of 12 (+12) bytes per record.
      const size_t op = offset[L.x];
      glm::vec3* pos = mesh_.positions.data() + done;
      if (mesh_.normals.empty()) {
        for (size_t i = 0; i < batch; ++i) std::memcpy(&pos[i], base + i * rec + op, 12);
      } else {
        const size_t on = offset[L.nx];
        glm::vec3* nrm = mesh_.normals.data() + done;
        for (size_t i = 0; i < batch; ++i) {
          std::memcpy(&pos[i], base + i * rec + op, 12);
          std::memcpy(&nrm[i], base + i * rec + on, 12);
        }
      }
    } else {
      for (size_t i = 0; i < batch; ++i) {
        const char* r = base + i * rec;
        for (size_t pi = 0; pi < e.props.size(); ++pi) vals[pi] = loadScalar(r + offset[pi], e.props[pi].type, false);
        storeVertex(done + i, e, L, vals.data());
      }
    }
    in_.consume(batch * rec);
    done += batch;
  }
  return Ok{};
}

Status PlyParser::readBinaryFastFaces(const Element& e) {
  constexpr size_t kMaxRecord = 1 + 255 * 4; // uchar count + up to 255 four-byte indices
  const uint64_t total = e.count;
  // Write through a cursor into a pre-sized array: the hot loop then is one 12-byte copy per triangle.
  auto& out = mesh_.indices;
  out.resize(size_t(total) * 3);
  size_t w = 0;
  uint32_t poly[255];
  uint64_t f = 0;
  while (f < total) {
    const bool atEof = !in_.ensure(kMaxRecord);
    const char* p = in_.data();
    const char* end = p + in_.available();
    while (f < total && p < end) {
      if (!atEof && size_t(end - p) < kMaxRecord) break; // the next record may spill: refill first
      unsigned n = static_cast<unsigned char>(*p);
      if (size_t(end - p) < 1 + size_t(n) * 4) break;
      if (n == 3 && w + 3 <= out.size()) {
        std::memcpy(&out[w], p + 1, 12);
        w += 3;
      } else {
        if (n < 3) return fail(fmt::format("face {} has {} vertices (need at least 3)", f, n));
        std::memcpy(poly, p + 1, size_t(n) * 4);
        size_t need = w + (size_t(n) - 2) * 3;
        if (need > out.size()) out.resize(need + size_t(total - f) * 3);
        for (size_t k = 1; k + 1 < n; ++k) {
          out[w++] = poly[0];
          out[w++] = poly[k];
          out[w++] = poly[k + 1];
        }
      }
      p += 1 + size_t(n) * 4;
      ++f;
    }
    size_t used = size_t(p - in_.data());
    if (used == 0) return truncated(e, f); // the file ended inside a record
    in_.consume(used);
  }
  out.resize(w);
  // Negative int indices read as huge unsigned values; validateMesh reports them as out of range.
  return Ok{};
}

template <class T> bool parseNumber(std::string_view tok, T& out) {
  auto [ptr, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), out);
  return ec == std::errc() && ptr == tok.data() + tok.size();
}

Status PlyParser::readAscii(const Element& e) {
  const bool vertex = isVertex(e);
  const bool face = isFace(e);
  VertexLayout L{};
  if (vertex) {
    L = vertexLayout(e);
    if (L.x < 0 || L.y < 0 || L.z < 0) return fail("PLY vertex element lacks x, y or z");
    beginVertices(e, L);
  }
  const bool strips = isStrips(e);
  int listProp = face || strips ? faceListProp(e) : -1;
  if (face || strips) {
    if (listProp < 0) return fail(fmt::format("PLY {} element has no vertex_indices list", quoteInput(e.name)));
    faceSeen_ = true;
    if (face) mesh_.indices.reserve(mesh_.indices.size() + size_t(e.count) * 3);
  }
  std::vector<double> vals(e.props.size());
  std::vector<uint32_t> poly;
  std::string_view tok;
  auto number = [&](uint64_t r, double& v) -> Status {
    if (!in_.token(tok)) return truncated(e, r);
    if (!parseNumber(tok, v))
      return fail(fmt::format("element {} record {}: bad number {}", quoteInput(e.name), r, quoteInput(tok, 32)));
    return Ok{};
  };
  for (uint64_t r = 0; r < e.count; ++r) {
    for (size_t pi = 0; pi < e.props.size(); ++pi) {
      const Property& p = e.props[pi];
      double v = 0;
      if (Status s = number(r, v); !s) return s;
      if (!p.isList()) {
        vals[pi] = v;
        continue;
      }
      // Every ascii value takes at least two bytes; strips often come as one record holding every index.
      if (v < 0 || v > double(fileSize_ / 2))
        return fail(fmt::format("element {} record {}: bad list length", quoteInput(e.name), r));
      size_t n = size_t(v);
      if (int(pi) == listProp) poly.resize(n);
      for (size_t k = 0; k < n; ++k) {
        double item = 0;
        if (Status s = number(r, item); !s) return s;
        if (int(pi) == listProp) poly[k] = toIndex(item);
      }
    }
    if (vertex) storeVertex(size_t(r), e, L, vals.data());
    if (face)
      if (Status st = addPolygon(poly.data(), poly.size(), r); !st) return st;
    if (strips) addStrip(poly.data(), poly.size());
  }
  return Ok{};
}

// Read past one record of `e` without keeping it; false when the file ends inside it or (ascii) a value is no number.
bool PlyParser::skipRecord(const Element& e) {
  for (const Property& p : e.props) {
    if (ascii_) {
      std::string_view tok;
      double v = 0;
      if (!in_.token(tok) || !parseNumber(tok, v)) return false;
      if (!p.isList()) continue;
      if (v < 0 || v > double(fileSize_ / 2)) return false;
      double item = 0;
      for (size_t k = 0; k < size_t(v); ++k)
        if (!in_.token(tok) || !parseNumber(tok, item)) return false;
      continue;
    }
    size_t head = typeSize(p.isList() ? p.countType : p.type);
    if (!in_.ensure(head)) return false;
    if (!p.isList()) {
      in_.consume(head);
      continue;
    }
    double cnt = loadScalar(in_.data(), p.countType, swap_);
    in_.consume(head);
    if (cnt < 0 || cnt * double(typeSize(p.type)) > double(fileSize_)) return false;
    size_t n = size_t(cnt) * typeSize(p.type);
    if (!in_.ensure(n)) return false;
    in_.consume(n);
  }
  return true;
}

// Anything after the last element means the header's counts are wrong (a face count too small drops triangles
// silently otherwise). Count the whole records of the last element that follow, to name both counts.
Status PlyParser::checkEnd() {
  if (in_.atEndAfterSpace(ascii_)) return Ok{};
  if (elements_.empty()) return fail("data after a header that declares no elements");
  const Element& last = elements_.back();
  const uint64_t dataEnd = in_.offset();
  uint64_t extra = 0;
  for (uint64_t before = in_.offset(); skipRecord(last) && in_.offset() > before; before = in_.offset()) {
    ++extra;
    if (in_.atEndAfterSpace(ascii_))
      return fail(fmt::format("element {} declares {} records, the data holds {}", quoteInput(last.name), last.count,
                              last.count + extra));
  }
  return fail(fmt::format("element {} declares {} records but {} more bytes follow them", quoteInput(last.name),
                          last.count, fileSize_ - dataEnd));
}

} // namespace

Result<Scene> importPly(const std::filesystem::path& path, const ImportOptions& options) {
  try {
    PlyParser parser(detail::displayName(path), options);
    return parser.run(path);
  } catch (const std::exception& e) { // bad_alloc on absurd inputs: an Error, never a throw
    return makeError(detail::displayName(path), fmt::format("import failed: {}", escapeInput(e.what(), 240)));
  }
}

} // namespace mirage::io
