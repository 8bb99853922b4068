// View cells: geometry, validation, JSON and grids (view_cell.h).
#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>

#include "mirage/visibility/ray_backend.h"
#include "mirage/visibility/view_cell.h"
#include "mirage/core/input_text.h"

namespace mirage::vis {

glm::mat3 ViewCell::axes() const {
  glm::vec3 r = glm::radians(rotation);
  glm::mat4 m = glm::rotate(glm::mat4(1.0f), r.z, {0, 0, 1});
  m = glm::rotate(m, r.y, {0, 1, 0});
  m = glm::rotate(m, r.x, {1, 0, 0});
  return glm::mat3(m);
}

glm::vec3 ViewCell::toWorld(glm::vec3 unit) const { return position + axes() * (unit * size); }

std::vector<glm::vec3> ViewCell::corners() const {
  std::vector<glm::vec3> out;
  for (int i = 0; i < 8; ++i) {
    if (shape == CellShape::Rect && (i & 2)) continue;
    glm::vec3 u((i & 1) ? 0.5f : -0.5f, (i & 2) ? 0.5f : -0.5f, (i & 4) ? 0.5f : -0.5f);
    if (shape == CellShape::Rect) u.y = 0.0f;
    out.push_back(toWorld(u));
  }
  return out;
}

std::vector<std::array<glm::vec3, 2>> ViewCell::edges() const {
  std::vector<std::array<glm::vec3, 2>> out;
  if (shape == CellShape::Rect) {
    // corners() order for a Rect: (-,-), (+,-), (-,+), (+,+) in (x, z).
    auto c = corners();
    out = {{c[0], c[1]}, {c[1], c[3]}, {c[3], c[2]}, {c[2], c[0]}};
    return out;
  }
  // Box corners indexed by bits (x, y, z); an edge joins corners differing in one bit.
  auto c = corners();
  for (int i = 0; i < 8; ++i)
    for (int bit = 1; bit < 8; bit <<= 1)
      if (!(i & bit)) out.push_back({c[i], c[i | bit]});
  return out;
}

float ViewCell::surfaceArea() const {
  if (shape == CellShape::Rect) return size.x * size.z;
  return 2.0f * (size.x * size.y + size.y * size.z + size.z * size.x);
}

Bounds ViewCell::bounds() const {
  Bounds b;
  for (glm::vec3 c : corners()) b.add(c);
  return b;
}

bool ViewCell::contains(glm::vec3 p) const {
  glm::vec3 local = glm::transpose(axes()) * (p - position);
  glm::vec3 half = size * 0.5f;
  // Rects get a thickness tolerance relative to their size so points computed on them count.
  float tol = 1e-4f * glm::max(size.x, glm::max(size.y, size.z));
  return std::abs(local.x) <= half.x + tol && std::abs(local.y) <= half.y + tol && std::abs(local.z) <= half.z + tol;
}

std::vector<CellFace> cellFaces(const ViewCell& cell) {
  glm::mat3 a = cell.axes();
  std::vector<CellFace> faces;
  if (cell.shape == CellShape::Rect) {
    CellFace f;
    f.corner = cell.toWorld({-0.5f, 0.0f, -0.5f});
    f.edgeU = a[0] * cell.size.x;
    f.edgeV = a[2] * cell.size.z;
    f.normal = a[1];
    f.area = cell.size.x * cell.size.z;
    faces.push_back(f);
    return faces;
  }
  for (int axis = 0; axis < 3; ++axis) {
    int u = (axis + 1) % 3, v = (axis + 2) % 3;
    for (float side : {-1.0f, 1.0f}) {
      CellFace f;
      glm::vec3 unit(0.0f);
      unit[axis] = 0.5f * side;
      unit[u] = -0.5f;
      unit[v] = -0.5f;
      f.corner = cell.toWorld(unit);
      f.edgeU = a[u] * cell.size[u];
      f.edgeV = a[v] * cell.size[v];
      f.normal = a[axis] * side;
      f.area = cell.size[u] * cell.size[v];
      faces.push_back(f);
    }
  }
  return faces;
}

namespace {

bool finite(glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

std::string vecText(glm::vec3 v) {
  std::ostringstream s;
  s << "[" << v.x << ", " << v.y << ", " << v.z << "]";
  return s.str();
}

} // namespace

Status validateCell(const ViewCell& cell, const std::string& where) {
  if (!finite(cell.position) || !finite(cell.size) || !finite(cell.rotation))
    return Error{where + ": non-finite position, size or rotation"};
  if (cell.shape == CellShape::Rect) {
    if (!(cell.size.x > 0.0f) || !(cell.size.z > 0.0f) || cell.size.y != 0.0f)
      return Error{where + ": degenerate rect (size " + vecText(cell.size) + "; needs positive x and z extents)"};
    if (std::min(cell.size.x, cell.size.z) <= 1e-6f * std::max(cell.size.x, cell.size.z))
      return Error{where + ": degenerate rect (size " + vecText(cell.size) + " is a line)"};
    return Ok{};
  }
  float largest = std::max(cell.size.x, std::max(cell.size.y, cell.size.z));
  float smallest = std::min(cell.size.x, std::min(cell.size.y, cell.size.z));
  // Relative, so the check means the same in millimetres and kilometres.
  if (!(smallest > 0.0f) || smallest <= 1e-6f * largest)
    return Error{where + ": degenerate box (size " + vecText(cell.size) + "; use \"type\": \"rect\" for a flat cell)"};
  return Ok{};
}

Status validateCellsForScene(const std::vector<ViewCell>& cells, const Bounds& sceneBounds, const std::string& where) {
  // The reach: the scene's bounds grown by kCellSceneDiagonals diagonals (a point-like scene gets
  // a margin relative to its position, so the test means the same in any unit).
  const bool haveScene = !sceneBounds.empty() && finite(sceneBounds.min) && finite(sceneBounds.max);
  Bounds reach;
  if (haveScene) {
    float diagonal = glm::length(sceneBounds.extent());
    float scale = std::max(std::abs(sceneBounds.center().x),
                           std::max(std::abs(sceneBounds.center().y), std::abs(sceneBounds.center().z)));
    float margin = kCellSceneDiagonals * std::max({diagonal, 1e-6f * scale, 1e-30f});
    reach.min = sceneBounds.min - glm::vec3(margin);
    reach.max = sceneBounds.max + glm::vec3(margin);
  }
  for (size_t i = 0; i < cells.size(); ++i) {
    const std::string cell = where + ": cell " + std::to_string(i);
    if (auto ok = validateCell(cells[i], cell); !ok) return ok;
    Bounds b = cells[i].bounds();
    float largest = std::max({std::abs(b.min.x), std::abs(b.min.y), std::abs(b.min.z), std::abs(b.max.x),
                              std::abs(b.max.y), std::abs(b.max.z)});
    if (!finite(b.min) || !finite(b.max) || !(largest <= kMaxRayCoordinate))
      return Error{cell + ": coordinates too large to ray trace (cell spans " + vecText(b.min) + " to " +
                   vecText(b.max) + ")"};
    if (haveScene && (glm::any(glm::lessThan(b.min, reach.min)) || glm::any(glm::greaterThan(b.max, reach.max))))
      return Error{cell + ": lies too far from the scene (cell spans " + vecText(b.min) + " to " + vecText(b.max) +
                   ", scene " + vecText(sceneBounds.min) + " to " + vecText(sceneBounds.max) +
                   "; cells must lie within " + std::to_string(int(kCellSceneDiagonals)) + " scene diagonals of it)"};
  }
  return Ok{};
}

namespace {

using nlohmann::json;

Result<glm::vec3> readVec(const json& j, const char* key, size_t count, const std::string& where) {
  const json& v = j.at(key);
  if (!v.is_array() || v.size() != count)
    return Error{where + ": \"" + key + "\" must be an array of " + std::to_string(count) + " numbers"};
  glm::vec3 out(0.0f);
  for (size_t i = 0; i < count; ++i) {
    if (!v[i].is_number()) return Error{where + ": \"" + key + "\" must hold numbers"};
    out[int(i)] = v[i].get<float>();
  }
  return out;
}

Result<ViewCell> parseCell(const json& j, const std::string& where) {
  if (!j.is_object()) return Error{where + ": must be an object"};
  for (auto it = j.begin(); it != j.end(); ++it)
    if (it.key() != "type" && it.key() != "position" && it.key() != "size" && it.key() != "rotation" &&
        it.key() != "name")
      return Error{where + ": unknown key \"" + it.key() + "\""};
  ViewCell c;
  std::string type = "box";
  if (j.contains("type")) {
    if (!j["type"].is_string()) return Error{where + ": \"type\" must be \"box\" or \"rect\""};
    type = j["type"].get<std::string>();
  }
  if (type == "box")
    c.shape = CellShape::Box;
  else if (type == "rect")
    c.shape = CellShape::Rect;
  else
    return Error{where + ": unknown type \"" + type + "\" (expected \"box\" or \"rect\")"};
  if (!j.contains("position")) return Error{where + ": missing \"position\""};
  if (!j.contains("size")) return Error{where + ": missing \"size\""};
  auto p = readVec(j, "position", 3, where);
  if (!p) return p.error();
  c.position = *p;
  auto s = readVec(j, "size", c.shape == CellShape::Box ? 3 : 2, where);
  if (!s) return s.error();
  c.size = c.shape == CellShape::Box ? *s : glm::vec3(s->x, 0.0f, s->y);
  if (j.contains("rotation")) {
    auto r = readVec(j, "rotation", 3, where);
    if (!r) return r.error();
    c.rotation = *r;
  }
  if (auto ok = validateCell(c, where); !ok) return ok.error();
  return c;
}

} // namespace

Result<std::vector<ViewCell>> parseViewCells(const std::string& jsonText, const std::string& file) {
  json doc = json::parse(jsonText, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded()) return makeError(file, "not valid JSON");
  const json* list = &doc;
  if (doc.is_object()) {
    if (!doc.contains("cells")) return makeError(file, "expected a \"cells\" array");
    list = &doc["cells"];
  }
  if (!list->is_array()) return makeError(file, "\"cells\" must be an array");
  if (list->empty()) return makeError(file, "no view cells");
  std::vector<ViewCell> cells;
  for (size_t i = 0; i < list->size(); ++i) {
    auto c = parseCell((*list)[i], file + ": cell " + std::to_string(i));
    if (!c) return c.error();
    cells.push_back(*c);
  }
  return cells;
}

Result<std::vector<ViewCell>> loadViewCells(const std::filesystem::path& path) {
  if (std::string problem = inputFileProblem(path); !problem.empty()) return makeError(path.string(), problem);
  std::ifstream in(path, std::ios::binary);
  if (!in) return makeError(path.string(), "cannot open");
  std::stringstream text;
  text << in.rdbuf();
  return parseViewCells(text.str(), path.string());
}

std::string viewCellsToJson(const std::vector<ViewCell>& cells) {
  json list = json::array();
  for (const ViewCell& c : cells) {
    json j;
    j["type"] = c.shape == CellShape::Box ? "box" : "rect";
    j["position"] = {c.position.x, c.position.y, c.position.z};
    if (c.shape == CellShape::Box)
      j["size"] = {c.size.x, c.size.y, c.size.z};
    else
      j["size"] = {c.size.x, c.size.z};
    j["rotation"] = {c.rotation.x, c.rotation.y, c.rotation.z};
    list.push_back(j);
  }
  return json{{"cells", list}}.dump(2);
}

Result<std::vector<ViewCell>> gridCells(const Bounds& region, glm::uvec3 counts) {
  if (region.empty() || !finite(region.min) || !finite(region.max)) return Error{"cell grid: empty region"};
  if (glm::any(glm::equal(counts, glm::uvec3(0)))) return Error{"cell grid: counts must be at least 1"};
  glm::vec3 ext = region.extent();
  bool flat = ext.y <= 1e-6f * std::max(ext.x, ext.z);
  if (flat && counts.y != 1) return Error{"cell grid: the region is flat in Y, so NY must be 1"};
  glm::vec3 step = ext / glm::vec3(counts);
  std::vector<ViewCell> cells;
  for (uint32_t z = 0; z < counts.z; ++z)
    for (uint32_t y = 0; y < counts.y; ++y)
      for (uint32_t x = 0; x < counts.x; ++x) {
        ViewCell c;
        c.shape = flat ? CellShape::Rect : CellShape::Box;
        c.size = flat ? glm::vec3(step.x, 0.0f, step.z) : step;
        c.position = region.min + step * (glm::vec3(x, y, z) + 0.5f);
        if (flat) c.position.y = region.min.y;
        if (auto ok = validateCell(c, "cell grid"); !ok) return ok.error();
        cells.push_back(c);
      }
  return cells;
}

Result<glm::uvec3> parseGridCounts(const std::string& text) {
  glm::uvec3 out(0);
  const char* p = text.data();
  const char* end = p + text.size();
  for (int i = 0; i < 3; ++i) {
    auto [next, ec] = std::from_chars(p, end, out[i]);
    if (ec != std::errc() || out[i] < 1 || out[i] > 1024)
      return Error{"--cell-grid: expected NXxNYxNZ with counts in 1..1024, got \"" + text + "\""};
    p = next;
    if (i < 2) {
      if (p == end || *p != 'x')
        return Error{"--cell-grid: expected NXxNYxNZ with counts in 1..1024, got \"" + text + "\""};
      ++p;
    }
  }
  if (p != end) return Error{"--cell-grid: trailing characters in \"" + text + "\""};
  return out;
}

} // namespace mirage::vis
