// Layers: a stack of alpha-blended quads, neighbours tilted the opposite way so that each cuts
// through the next ones: the transparency benchmark (every covered pixel holds about `layers`
// blended fragments) and a case that sorting whole objects or triangles gets wrong.
#include <cmath>

#include <glm/gtc/matrix_transform.hpp>

#include "generate_common.h"
#include "mirage/io/generate.h"

namespace mirage::io {

Scene generateLayers(const LayersOptions& o) {
  Scene scene;
  scene.source = "generated:layers";
  for (uint32_t i = 0; i < o.layers; ++i) {
    Mesh mesh;
    mesh.name = "layer" + std::to_string(i);
    mesh.material = i;
    mesh.positions = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
    mesh.normals.assign(4, glm::vec3(0, 0, 1));
    mesh.uv0 = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    mesh.indices = {0, 1, 2, 0, 2, 3};
    detail::computeBounds(mesh);
    scene.meshes.push_back(std::move(mesh));
    // Hues around the wheel, so a wrong order shows as a wrong colour.
    float h = float(i) / float(o.layers) * 6.2831853f;
    Material m;
    m.name = "layer" + std::to_string(i);
    m.baseColorFactor = glm::vec4(0.5f + 0.45f * std::cos(h), 0.5f + 0.45f * std::cos(h - 2.094f),
                                  0.5f + 0.45f * std::cos(h + 2.094f), o.alpha);
    m.metallicFactor = 0.0f;
    m.roughnessFactor = 0.8f;
    m.alphaMode = AlphaMode::Blend;
    m.doubleSided = true;
    scene.materials.push_back(m);
    float z = (float(i) - 0.5f * float(o.layers - 1)) * o.spacing;
    float tilt = glm::radians(i % 2 ? -o.tiltDegrees : o.tiltDegrees);
    glm::mat4 t = glm::rotate(glm::translate(glm::mat4(1.0f), glm::vec3(0, 0, z)), tilt, glm::vec3(0, 1, 0));
    scene.instances.push_back({i, t});
  }
  return scene;
}

} // namespace mirage::io
