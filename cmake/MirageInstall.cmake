# `cmake --install`: public headers (include/mirage, shaderio included), every module's static
# library and the embedded shaders as Mirage::<module> targets of a CMake package
# (find_package(Mirage)), one pkg-config file (mirage.pc) and the mirage CLI.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(MIRAGE_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/Mirage)

# Installed modules in link order (a library before the ones it uses): static archives are read
# once, in this order, by linkers that take a flat list (mirage.pc).
set(mirage_link_order "")
foreach(module stream stream_net stream_atlas stream_web runtime render shading particles particles_cpu visibility visibility_cpu surfels surfels_cpu lod io
               gpu shaders asset core)
  if(TARGET mirage_${module})
    list(APPEND mirage_link_order mirage_${module})
  endif()
endforeach()
set_target_properties(mirage_shaders PROPERTIES EXPORT_NAME shaders)
string(REPLACE "mirage_" "" MIRAGE_EXPORT_NAMES "${mirage_link_order}")
string(REPLACE ";" " " MIRAGE_EXPORT_NAMES "${MIRAGE_EXPORT_NAMES}")

install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/mirage DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} FILES_MATCHING PATTERN "*.h")
# (Their include directory comes from $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>, see mirage_module.)
install(TARGETS ${mirage_link_order} EXPORT MirageTargets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(TARGETS mirage RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})

install(EXPORT MirageTargets NAMESPACE Mirage:: DESTINATION ${MIRAGE_CMAKE_DIR})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/MirageConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/MirageConfig.cmake INSTALL_DESTINATION ${MIRAGE_CMAKE_DIR})
# 0.x: a minor version may change the API.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/MirageConfigVersion.cmake VERSION ${PROJECT_VERSION}
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/MirageConfig.cmake ${PROJECT_BINARY_DIR}/MirageConfigVersion.cmake
              ${PROJECT_SOURCE_DIR}/cmake/FindMETIS.cmake DESTINATION ${MIRAGE_CMAKE_DIR})

# pkg-config: one file for all modules. The archives need a fixed order and the third-party
# libraries after them, which per-module files could not give in one `pkg-config --libs` line.
set(MIRAGE_PC_LIBS "")
foreach(lib ${mirage_link_order})
  string(APPEND MIRAGE_PC_LIBS " -l${lib}")
endforeach()
set(MIRAGE_PC_DL "")
foreach(lib ${CMAKE_DL_LIBS}) # mirage_gpu loads the Vulkan loader at run time (volk)
  string(APPEND MIRAGE_PC_DL " -l${lib}")
endforeach()
# The prefix relative to the .pc file (${pcfiledir}), so that `cmake --install --prefix` anywhere works.
file(RELATIVE_PATH MIRAGE_PC_PREFIX /root/${CMAKE_INSTALL_LIBDIR}/pkgconfig /root)
string(REGEX REPLACE "/$" "" MIRAGE_PC_PREFIX "${MIRAGE_PC_PREFIX}")
configure_file(${PROJECT_SOURCE_DIR}/cmake/mirage.pc.in ${PROJECT_BINARY_DIR}/mirage.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/mirage.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
