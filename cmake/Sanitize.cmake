# Initial cache of the sanitized build (`make test-sanitize`, `make fuzz`; cmake -C cmake/Sanitize.cmake):
# clang with AddressSanitizer and UndefinedBehaviorSanitizer on every Mirage target (UB aborts, so
# ctest sees it), libFuzzer's coverage instrumentation too so the same build makes the fuzz targets,
# and libstdc++'s assertions (bounds of operator[] on vectors and spans). -O1: the sanitizers' usual
# level; it also compiles faster than Release on CI's two cores.
set(CMAKE_C_COMPILER clang-14 CACHE STRING "")
set(CMAKE_CXX_COMPILER clang++-14 CACHE STRING "")
set(CMAKE_BUILD_TYPE Sanitize CACHE STRING "")
set(mirage_sanitize "-O1 -gline-tables-only -fno-omit-frame-pointer -fsanitize=address,undefined -fno-sanitize-recover=undefined")
set(CMAKE_C_FLAGS_SANITIZE "${mirage_sanitize} -fsanitize=fuzzer-no-link" CACHE STRING "")
set(CMAKE_CXX_FLAGS_SANITIZE "${mirage_sanitize} -fsanitize=fuzzer-no-link -D_GLIBCXX_ASSERTIONS" CACHE STRING "")
set(CMAKE_EXE_LINKER_FLAGS_SANITIZE "-fsanitize=address,undefined" CACHE STRING "")
set(CMAKE_SHARED_LINKER_FLAGS_SANITIZE "-fsanitize=address,undefined" CACHE STRING "")
set(MIRAGE_FUZZ ON CACHE BOOL "")
set(MIRAGE_BENCH OFF CACHE BOOL "")
# Bakes in one process: Open MPI's allocations at MPI_Init read as leaks to LSan and its launcher is
# not instrumented (the MPI paths run in the normal build; docs/bake.md).
set(MIRAGE_MPI OFF CACHE BOOL "")
