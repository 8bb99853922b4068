#pragma once
// View cells: the regions a PVS is computed for. A cell is an oriented box (3D) or an oriented
// rectangle (2D, e.g. a walkable floor area). Sampling a cell for from-region visibility means
// sampling *lines through the region*, not only rays leaving it (docs/visibility.md, "View cells"):
// origins lie on the cell's surface and directions cover the whole sphere. A direction in the
// outward hemisphere of a face sees what lies outside; one in the inward hemisphere crosses the
// cell, so it sees geometry inside the cell and, if nothing stops it there, leaves through the
// opposite face exactly like an outward ray from that face would. No face is sampled one-sided.
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"

namespace mirage::vis {

enum class CellShape : uint8_t { Box = 0, Rect = 1 };

struct ViewCell {
  CellShape shape = CellShape::Box;
  glm::vec3 position{0.0f}; // centre, world space
  glm::vec3 size{1.0f};     // full extents along the local axes; a Rect spans local X and Z (size.y == 0)
  glm::vec3 rotation{0.0f}; // Euler angles in degrees: local → world is Rz · Ry · Rx

  // Local axes in world space (columns), unit length.
  glm::mat3 axes() const;
  // Local point in [-0.5, 0.5]^3 (scaled by size) to world.
  glm::vec3 toWorld(glm::vec3 unit) const;
  // Box: 8 corners; Rect: 4 corners.
  std::vector<glm::vec3> corners() const;
  // Edges as corner pairs: Box 12, Rect 4.
  std::vector<std::array<glm::vec3, 2>> edges() const;
  float surfaceArea() const;
  // World bounds of the corners.
  Bounds bounds() const;
  // True when `p` lies inside the cell (within a relative tolerance for Rects).
  bool contains(glm::vec3 p) const;
};

// One face of a cell's surface: origin corner plus two spanning edges; `normal` points outward
// (for a Rect, its one face has both sides outward: callers sample the full sphere anyway).
struct CellFace {
  glm::vec3 corner{0.0f};
  glm::vec3 edgeU{0.0f};
  glm::vec3 edgeV{0.0f};
  glm::vec3 normal{0.0f};
  float area = 0.0f;
};
// Box: 6 faces; Rect: 1.
std::vector<CellFace> cellFaces(const ViewCell& cell);

// Rejects non-finite values and degenerate cells: a Box with an extent ≤ 1e-6 of its largest one
// (or ≤ 0), a Rect with a non-positive X or Z extent. `where` prefixes the message (e.g. "cell 3").
Status validateCell(const ViewCell& cell, const std::string& where);

// Cells must lie where rays from them can be traced against the scene: within
// kCellSceneDiagonals scene diagonals of its bounds (a cell 1e30 away from a 100 m city makes ray
// origins that Embree rejects and that no float hit test could resolve anyway). `where` prefixes
// each message (the cells file or the flag); errors name the cell index. Empty scene bounds only
// get the absolute limit (kMaxRayCoordinate, ray_backend.h).
inline constexpr float kCellSceneDiagonals = 1000.0f;
Status validateCellsForScene(const std::vector<ViewCell>& cells, const Bounds& sceneBounds, const std::string& where);

// JSON: {"cells": [ {"type": "box", "position": [x,y,z], "size": [sx,sy,sz], "rotation": [rx,ry,rz]},
//                   {"type": "rect", "position": [...], "size": [sx,sz], "rotation": [...]} ]}
// or a bare array of cells; "rotation" is optional (degrees). Errors: "<file>: cell N: <problem>".
Result<std::vector<ViewCell>> parseViewCells(const std::string& jsonText, const std::string& fileForErrors);
Result<std::vector<ViewCell>> loadViewCells(const std::filesystem::path& path);
std::string viewCellsToJson(const std::vector<ViewCell>& cells);

// counts.x × counts.y × counts.z boxes tiling `region` (x fastest); when the region is flat in Y,
// counts.y must be 1 and the cells are Rects at region.min.y.
Result<std::vector<ViewCell>> gridCells(const Bounds& region, glm::uvec3 counts);
// "NXxNYxNZ" (each 1..1024) for --cell-grid.
Result<glm::uvec3> parseGridCounts(const std::string& text);

} // namespace mirage::vis
