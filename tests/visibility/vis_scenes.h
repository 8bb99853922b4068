#pragma once
// Synthetic scenes with known from-region visibility for the visibility tests.
#include "mirage/core/scene.h"
#include "mirage/visibility/view_cell.h"

namespace mirage::test {

// A scene whose meshes are named parts; `cell` is the view cell the test bakes for.
struct VisScene {
  Scene scene;
  vis::ViewCell cell;
};

// Wall at z = 0 (20×20) with a 2×2 hole; cell (unit box) at z = -3. Behind the wall: "target"
// (z = 5, seen through the hole), "hidden" (z = 5, x in [6, 9]: no line through the hole reaches
// it) and "backdrop" (z = 10, 40×40 grid of 800 triangles, partly seen).
VisScene wallWithHole();
// Closed room [-5, 5]^3 with a 2×2 window in its +Z wall; cell (2×2×2) in the middle. Outside:
// "tree" in front of the window (seen), "shed" beside it (x in [5, 7], z = 8: hidden), "back"
// behind the room (hidden).
VisScene roomWithWindow();
// See-through materials: glass panes ("front", Blend material; 20×20 at z = 1, 2 and 3), an opaque
// "wall" (z = 5) and a pane "behind" it (z = 7); `cell` sits at z = -1 in front of them.
VisScene glassPanes();
// The generated city (`gen:city`, seed 4) of `blocks` blocks, and a 4 x 2 x 4 view cell over its
// street at z = -38 (eye height 1.7).
Scene cityScene(uint32_t blocks);
vis::ViewCell streetCell();
// Triangles of mesh `name` as global IDs (each mesh has one identity instance in these scenes).
std::vector<uint32_t> meshTriangles(const Scene& scene, const std::string& name);

} // namespace mirage::test
