#pragma once
// Octahedral unit-vector encoding (Meyer et al. 2010) as two snorm16 components packed in 32 bits
// (x in the low half): ~1e-4 rad angular error. Used by surfels and the cluster-DAG codec.
#include <cstdint>

#include <glm/glm.hpp>

namespace mirage {

uint32_t encodeOctahedral(glm::vec3 n);
glm::vec3 decodeOctahedral(uint32_t packed);

} // namespace mirage
