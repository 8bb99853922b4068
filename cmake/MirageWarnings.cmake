# Strict warnings on Mirage's own targets; third-party headers come from /usr/include (system).
# -Wfloat-conversion: implicit double->float and float->int truncations. -Wconversion (int narrowing,
# int->float) and -Wsign-conversion were measured and left out: over 200 index/size/count casts, no bug among them.
function(mirage_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wfloat-conversion
                                           -Wno-missing-field-initializers)
  if(CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    # clang files double->float precision loss under this group, not under -Wfloat-conversion as GCC.
    target_compile_options(${target} PRIVATE -Wimplicit-float-conversion -Wno-implicit-int-float-conversion)
  endif()
  if(CMAKE_BUILD_TYPE STREQUAL "Debug")
    target_compile_definitions(${target} PRIVATE _GLIBCXX_ASSERTIONS)
  endif()
endfunction()

# Code that only drives the libraries (test bodies, the CLI's flag binding and printing) compiles at
# -O1 in optimized builds: the work it starts runs in the libraries at full optimization, while -O1
# halves its compile time (gtest and CLI11 templates; the tests and the CLI were half and a fifth of
# the Release build's compile time on 2 cores). Measured: cmd_build.cpp 65 s at -O3, 34 s at -O1; a
# test file 29 -> 18 s; the whole test suite's run time the same (205 s either way).
set(MIRAGE_DRIVER_OPTIMIZATION $<$<CONFIG:Release,RelWithDebInfo,MinSizeRel>:-O1>)

include(GNUInstallDirs) # CMAKE_INSTALL_INCLUDEDIR of the installed targets

# mirage_module(name SOURCES...): a static library with public headers in include/mirage/<name>.
function(mirage_module name)
  add_library(mirage_${name} STATIC ${ARGN})
  add_library(mirage::${name} ALIAS mirage_${name})
  target_include_directories(mirage_${name} PUBLIC $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/include>
                             $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}> PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
  # Installed as Mirage::<name> (cmake/MirageInstall.cmake).
  set_target_properties(mirage_${name} PROPERTIES EXPORT_NAME ${name})
  mirage_warnings(mirage_${name})
endfunction()

# Code whose files each include the same header-only libraries (CLI11, fmt and nlohmann/json in the CLI;
# gtest in the tests) compiles in unity batches: their inline code is compiled once a batch rather than
# once a file, a third of the CLI's compile time. Names at file scope must then be unique within a
# target. -DMIRAGE_UNITY_BUILD=OFF compiles file by file (the same code).
option(MIRAGE_UNITY_BUILD "Compile the CLI and the tests in unity batches" ON)
function(mirage_unity_build target)
  if(MIRAGE_UNITY_BUILD)
    set_target_properties(${target} PROPERTIES UNITY_BUILD ON UNITY_BUILD_BATCH_SIZE 8)
  endif()
endfunction()
