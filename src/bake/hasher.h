#pragma once
// The fingerprints of LOD bakes (lodFingerprint, streamFingerprint): XXH3-64 over values
// and arrays, each array preceded by its length so that no two inputs hash the same bytes.
#include <cstdint>
#include <span>

#include <xxhash.h>

namespace mirage::bake {

struct Hasher {
  Hasher() : state(XXH3_createState()) { XXH3_64bits_reset(state); }
  ~Hasher() { XXH3_freeState(state); }
  Hasher(const Hasher&) = delete;
  Hasher& operator=(const Hasher&) = delete;
  template <class T> void add(std::span<const T> values) {
    uint64_t n = values.size();
    XXH3_64bits_update(state, &n, sizeof n);
    XXH3_64bits_update(state, values.data(), values.size_bytes());
  }
  template <class T> void add(const T& value) { add(std::span<const T>(&value, 1)); }
  uint64_t digest() const { return XXH3_64bits_digest(state); }
  XXH3_state_t* state;
};

} // namespace mirage::bake
