# Installing radlab as a CMake package (docs/library.md): `cmake --install build --prefix P`
# puts the headers under P/include/radlab/, the static libraries under P/lib, `radlab` under
# P/bin and radlabConfig.cmake under P/lib/cmake/radlab, so that a project outside the tree does
#   find_package(radlab REQUIRED)
#   add_library(my_solver MODULE my_solver.cpp)
#   target_link_libraries(my_solver PRIVATE radlab::plugin)
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

# The headers are installed from each library's header file set (cmake/RadlabLibrary.cmake):
# <folder>/<role>/x.h in the tree is <prefix>/include/radlab/<folder>/<role>/x.h, and the
# installed targets put <prefix>/include/radlab on the include path, so every include keeps the
# spelling it has in the tree ("solvers/solver.h").
# radlab::plugin: the headers and their header-only dependencies, no library. A plugin resolves
# radlab's symbols against the executable that loads it (ENABLE_EXPORTS on radlab).
add_library(radlab_plugin INTERFACE)
target_include_directories(radlab_plugin INTERFACE $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}>
                                                   $<BUILD_INTERFACE:${PROJECT_BINARY_DIR}/generated>
                                                   $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}/radlab>)
target_link_libraries(radlab_plugin INTERFACE glm::glm nlohmann_json::nlohmann_json)
target_compile_features(radlab_plugin INTERFACE cxx_std_20)

set(radlab_exported radlab_core radlab_scene radlab_formfactor radlab_solvers radlab_metrics
                    radlab_render radlab_experiments radlab_plugin)
foreach(target IN LISTS radlab_exported)
  string(REPLACE "radlab_" "" short ${target})
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${short})
endforeach()
install(TARGETS ${radlab_exported} radlab EXPORT radlabTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
        FILE_SET HEADERS DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/radlab
        FILE_SET generated DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/radlab)
install(EXPORT radlabTargets NAMESPACE radlab:: FILE radlabTargets.cmake
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/radlab)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/radlabConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/radlabConfig.cmake
                              INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/radlab)
# C++ has no stable ABI: a plugin needs the exact version (the loader checks it too).
write_basic_package_version_file(${PROJECT_BINARY_DIR}/radlabConfigVersion.cmake
                                 COMPATIBILITY ExactVersion)
install(FILES ${PROJECT_BINARY_DIR}/radlabConfig.cmake ${PROJECT_BINARY_DIR}/radlabConfigVersion.cmake
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/radlab)
