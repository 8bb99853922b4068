# mirage_stream_atlas: the CPU side of the shading atlas (patches, atlas allocator, atlas image
# codecs: lossless zstd tile deltas and H.264 through libavcodec; streamed particles' looks). No Vulkan. docs/stream.md.
pkg_check_modules(LIBAV REQUIRED IMPORTED_TARGET libavcodec libavutil libswscale)
add_library(mirage_stream_atlas STATIC
  ${CMAKE_CURRENT_LIST_DIR}/patches.cpp
  ${CMAKE_CURRENT_LIST_DIR}/tessellate.cpp
  ${CMAKE_CURRENT_LIST_DIR}/atlas.cpp
  ${CMAKE_CURRENT_LIST_DIR}/particle_looks.cpp
  ${CMAKE_CURRENT_LIST_DIR}/tile_codec.cpp
  ${CMAKE_CURRENT_LIST_DIR}/video.cpp
  ${CMAKE_CURRENT_LIST_DIR}/link_budget.cpp)
add_library(mirage::stream_atlas ALIAS mirage_stream_atlas)
target_include_directories(mirage_stream_atlas PUBLIC $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/include>
                           $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}> PRIVATE ${CMAKE_CURRENT_LIST_DIR})
set_target_properties(mirage_stream_atlas PROPERTIES EXPORT_NAME stream_atlas)
target_link_libraries(mirage_stream_atlas PUBLIC mirage_core mirage_particles_cpu PRIVATE fmt::fmt PkgConfig::ZSTD PkgConfig::LIBAV)
mirage_warnings(mirage_stream_atlas)
