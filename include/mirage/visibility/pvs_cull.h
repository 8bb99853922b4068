#pragma once
// Run-time use of a baked PVS: the scene restricted to what the camera's view cell can see.
#include <span>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/core/scene.h"
#include "mirage/visibility/view_cell.h"

namespace mirage::vis {

// The first cell containing `p`, or -1.
int findCell(const std::vector<ViewCell>& cells, glm::vec3 p);

// `scene` keeping only the triangles listed (sorted global IDs, instance-major as in
// triangleOffsets): every instance with any listed triangle gets its own mesh of just those;
// materials, textures and transforms are kept. Errors when an ID is outside the scene.
Result<Scene> restrictToPvs(const Scene& scene, std::span<const uint32_t> sortedTriangleIds);

} // namespace mirage::vis
