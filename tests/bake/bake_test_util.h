#pragma once
// Shared by the bake tests: the process's world.
#include <cstdio>
#include <cstdlib>
#include <utility>

#include "mirage/bake/world.h"

namespace mirage::test {

// One world per process (MPI is initialized once), finalized at exit: of one, unless under mpirun
// (where only the Distributed.* tests run).
inline const bake::World& world() {
  static bake::World w = [] {
    auto joined = bake::World::join();
    if (!joined) {
      std::fprintf(stderr, "%s\n", joined.error().message.c_str());
      std::abort();
    }
    return std::move(joined).value();
  }();
  return w;
}

} // namespace mirage::test
