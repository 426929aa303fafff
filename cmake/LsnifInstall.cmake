# Install rules, the CMake package (lsnifConfig.cmake: lsnif::vk; COMPONENTS train: lsnif::format,
# lsnif::core, lsnif::import, lsnif::train), the pkg-config file (lsnif.pc) and the CPack DEB
# packages, one per install component:
#   runtime    liblsnif-vk0        lib/liblsnif_vk.so.0*
#   dev        liblsnif-dev        headers + GLSL includes (include/lsnif/*), liblsnif_vk.so, cmake config, lsnif.pc
#   train-dev  liblsnif-train-dev  the static CPU libraries and their headers (include/lsnif/<folder>/*)
# Installed headers keep their source paths under one root: src/lsnif/core/model.h is
# include/lsnif/core/model.h, included as "lsnif/core/model.h", so no installed name can shadow a
# consumer's own config.h, model.h or host_device.h.
#   tools      lsnif-tools         bin/lsnif
#   python     python3-lsnif       lib/python3/dist-packages/lsnif (the Python module, docs/python.md)
# Every installed file is relocatable: the config and lsnif.pc locate the prefix from their own path.
include(CMakePackageConfigHelpers)

set(LSNIF_COMPONENTS runtime dev)
set(LSNIF_PACKAGES liblsnif-vk0 liblsnif-dev)
if(LSNIF_BUILD_TRAIN)
  list(APPEND LSNIF_COMPONENTS train-dev)
  list(APPEND LSNIF_PACKAGES liblsnif-train-dev)
endif()
if(LSNIF_BUILD_TOOLS)
  list(APPEND LSNIF_COMPONENTS tools)
  list(APPEND LSNIF_PACKAGES lsnif-tools)
endif()
if(LSNIF_BUILD_PYTHON)
  list(APPEND LSNIF_COMPONENTS python)
  list(APPEND LSNIF_PACKAGES python3-lsnif)
endif()

set(LSNIF_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/lsnif)
set(LSNIF_INSTALL_INCLUDEDIR ${CMAKE_INSTALL_INCLUDEDIR}/lsnif)
# GLSL includes them by the same paths: `#include "lsnif/lsnif_hit.glsl"` with -I include.
set(LSNIF_INSTALL_GLSLDIR ${CMAKE_INSTALL_INCLUDEDIR})

# ---- the plugin: lsnif::vk
set_target_properties(lsnif_vk PROPERTIES EXPORT_NAME vk)
install(TARGETS lsnif_vk EXPORT lsnifTargets
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT runtime NAMELINK_COMPONENT dev)
install(FILES ${LSNIF_SOURCE_ROOT}/lsnif/lsnif.h ${LSNIF_SOURCE_ROOT}/lsnif/lsnif.hpp
  ${LSNIF_GENERATED_ROOT}/lsnif/lsnif_version.h ${LSNIF_SOURCE_ROOT}/lsnif/host_device.h
  ${LSNIF_SOURCE_ROOT}/lsnif/lsnif_hit.glsl ${LSNIF_SOURCE_ROOT}/lsnif/lsnif_hit.hlsl
  DESTINATION ${LSNIF_INSTALL_INCLUDEDIR} COMPONENT dev)
# The intersection shader's source, for an application that builds it for its own layout
# (lsnif/shaders/lsnif_intersection.glsl: the model lookup chosen by macros) and the pieces it includes.
install(FILES ${LSNIF_SOURCE_ROOT}/lsnif/shaders/lsnif.rint
  ${LSNIF_SOURCE_ROOT}/lsnif/shaders/lsnif_intersection.glsl ${LSNIF_SOURCE_ROOT}/lsnif/shaders/lsnif_intersect.glsl
  ${LSNIF_SOURCE_ROOT}/lsnif/shaders/lsnif_head.glsl ${LSNIF_SOURCE_ROOT}/lsnif/shaders/lsnif_mlp.glsl
  ${LSNIF_SOURCE_ROOT}/lsnif/shaders/lsnif_encoding.glsl ${LSNIF_SOURCE_ROOT}/lsnif/shaders/lsnif_walk.glsl
  ${LSNIF_SOURCE_ROOT}/lsnif/shaders/lsnif_perfect_hash.glsl ${LSNIF_SOURCE_ROOT}/lsnif/shaders/lsnif_model.glsl
  ${LSNIF_SOURCE_ROOT}/lsnif/shaders/lsnif_uv_cells.glsl
  DESTINATION ${LSNIF_INSTALL_INCLUDEDIR}/shaders COMPONENT dev)
install(EXPORT lsnifTargets NAMESPACE lsnif:: DESTINATION ${LSNIF_INSTALL_CMAKEDIR} COMPONENT dev)
# The guides a renderer engineer reads beside the package (their repository paths are marked as
# such; the package test checks that every other path they name is installed).
install(FILES ${PROJECT_SOURCE_DIR}/docs/integration.md ${PROJECT_SOURCE_DIR}/docs/model-format.md
  DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/lsnif COMPONENT dev)
install(FILES ${PROJECT_SOURCE_DIR}/docs/images/hello_lsnif.png DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/lsnif/images
  COMPONENT dev)
# The examples, buildable from the installed package alone (docs/integration.md): hello_lsnif, the
# whole integration in one C11 file, and with -DHELLO_LSNIF_BUILD_ENGINE=ON its own-layout engine.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/samples/hello_lsnif/ DESTINATION ${CMAKE_INSTALL_DATADIR}/lsnif/examples/hello_lsnif
  COMPONENT dev)

# ---- the CPU libraries: COMPONENTS train. lsnif_format is exported here only: lsnif::vk links it
# privately into the shared library.
if(LSNIF_BUILD_TRAIN)
  foreach(folder format core import train)
    set_target_properties(lsnif_${folder} PROPERTIES EXPORT_NAME ${folder})
    # Every header of the folder: test helpers live in src/lsnif/testing/, which is not installed.
    file(GLOB headers ${LSNIF_SOURCE_ROOT}/lsnif/${folder}/*.h)
    install(FILES ${headers} DESTINATION ${LSNIF_INSTALL_INCLUDEDIR}/${folder} COMPONENT train-dev)
  endforeach()
  # The one include root; format's headers include lsnif/host_device.h (installed by the dev component).
  target_include_directories(lsnif_format INTERFACE $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  install(TARGETS lsnif_format lsnif_core lsnif_import lsnif_train EXPORT lsnifTrainTargets
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT train-dev)
  install(EXPORT lsnifTrainTargets NAMESPACE lsnif:: DESTINATION ${LSNIF_INSTALL_CMAKEDIR} COMPONENT train-dev)
endif()

# ---- the lsnif program
if(LSNIF_BUILD_TOOLS)
  # Finds the installed liblsnif_vk beside it wherever the prefix is.
  file(RELATIVE_PATH lsnif_bin_to_lib /prefix/${CMAKE_INSTALL_BINDIR} /prefix/${CMAKE_INSTALL_LIBDIR})
  set_target_properties(lsnif PROPERTIES INSTALL_RPATH "$ORIGIN/${lsnif_bin_to_lib}")
  install(TARGETS lsnif RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT tools)
  # The OpenImageIO module it opens at its first image call, where it looks for it (src/lsnif/image).
  install(TARGETS lsnif_image_oiio LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/lsnif COMPONENT tools)
endif()

# ---- the Python module: the package lsnif (its extension finds the installed liblsnif_vk beside it)
if(LSNIF_BUILD_PYTHON)
  set(LSNIF_PYTHON_INSTALL_DIR lib/python3/dist-packages CACHE STRING
    "Where the Python package lsnif is installed, relative to the prefix (Debian's python3 reads /usr/lib/python3/dist-packages)")
  file(RELATIVE_PATH lsnif_python_to_lib /prefix/${LSNIF_PYTHON_INSTALL_DIR}/lsnif /prefix/${CMAKE_INSTALL_LIBDIR})
  set_target_properties(lsnif_python PROPERTIES INSTALL_RPATH "$ORIGIN/${lsnif_python_to_lib}")
  install(TARGETS lsnif_python LIBRARY DESTINATION ${LSNIF_PYTHON_INSTALL_DIR}/lsnif COMPONENT python)
  install(FILES ${LSNIF_PYTHON_PACKAGE_DIR}/__init__.py ${LSNIF_PYTHON_PACKAGE_DIR}/_build_info.py
    DESTINATION ${LSNIF_PYTHON_INSTALL_DIR}/lsnif COMPONENT python)
endif()

# ---- the license in every package, where Debian keeps it
foreach(component package IN ZIP_LISTS LSNIF_COMPONENTS LSNIF_PACKAGES)
  install(FILES ${PROJECT_SOURCE_DIR}/LICENSE DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/${package}
    RENAME copyright COMPONENT ${component})
endforeach()

# ---- lsnifConfig.cmake, lsnifConfigVersion.cmake
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/lsnifConfig.cmake.in
  ${PROJECT_BINARY_DIR}/package/lsnifConfig.cmake INSTALL_DESTINATION ${LSNIF_INSTALL_CMAKEDIR}
  PATH_VARS CMAKE_INSTALL_INCLUDEDIR LSNIF_INSTALL_GLSLDIR)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/package/lsnifConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMajorVersion)
install(FILES ${PROJECT_BINARY_DIR}/package/lsnifConfig.cmake ${PROJECT_BINARY_DIR}/package/lsnifConfigVersion.cmake
  DESTINATION ${LSNIF_INSTALL_CMAKEDIR} COMPONENT dev)

# ---- lsnif.pc: the prefix is found from the file's own folder (${pcfiledir}).
set(LSNIF_INSTALL_PKGCONFIGDIR ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
file(RELATIVE_PATH LSNIF_PC_TO_PREFIX /prefix/${LSNIF_INSTALL_PKGCONFIGDIR} /prefix)
string(REGEX REPLACE "/$" "" LSNIF_PC_TO_PREFIX "${LSNIF_PC_TO_PREFIX}")
configure_file(${PROJECT_SOURCE_DIR}/cmake/lsnif.pc.in ${PROJECT_BINARY_DIR}/package/lsnif.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/package/lsnif.pc DESTINATION ${LSNIF_INSTALL_PKGCONFIGDIR} COMPONENT dev)

# ---- CPack: `cpack -G DEB` in the build folder writes one .deb per component.
set(CPACK_PACKAGE_NAME lsnif)
set(CPACK_PACKAGE_VENDOR "LSNIF")
set(CPACK_PACKAGE_CONTACT "LSNIF maintainers <lsnif@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "LSNIF: neural intersection functions for Vulkan ray tracing")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_ALL ${LSNIF_COMPONENTS})
foreach(component package IN ZIP_LISTS LSNIF_COMPONENTS LSNIF_PACKAGES)
  string(TOUPPER ${component} upper)
  set(CPACK_DEBIAN_${upper}_PACKAGE_NAME ${package})
endforeach()
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION libs)
# Versioned dependencies between the packages of one build (liblsnif-dev -> liblsnif-vk0 (= version)).
set(CPACK_DEBIAN_ENABLE_COMPONENT_DEPENDS ON)

set(CPACK_COMPONENT_RUNTIME_DESCRIPTION "LSNIF Vulkan plugin library (liblsnif_vk.so.0)
 Neural intersection functions for Vulkan ray tracing: the shared library an application loads.")
set(CPACK_DEBIAN_RUNTIME_PACKAGE_SHLIBDEPS ON)

set(CPACK_DEBIAN_DEV_PACKAGE_SECTION libdevel)
set(CPACK_COMPONENT_DEV_DESCRIPTION "LSNIF Vulkan plugin: headers, GLSL includes, CMake and pkg-config files
 find_package(lsnif) gives lsnif::vk, pkg-config --cflags --libs lsnif the flags; the GLSL
 includes for closest-hit shaders are /usr/include/lsnif/lsnif_hit.glsl (HLSL: lsnif_hit.hlsl) and
 host_device.h; the intersection shader's source is /usr/include/lsnif/shaders/lsnif_intersection.glsl.")
set(CPACK_COMPONENT_DEV_DEPENDS runtime)
set(CPACK_DEBIAN_DEV_PACKAGE_DEPENDS "libvulkan-dev")

set(CPACK_DEBIAN_TRAIN-DEV_PACKAGE_SECTION libdevel)
set(CPACK_COMPONENT_TRAIN-DEV_DESCRIPTION "LSNIF CPU libraries (static): model format, inference, import, training
 find_package(lsnif COMPONENTS train) gives lsnif::format, lsnif::core, lsnif::import and
 lsnif::train.")
set(CPACK_COMPONENT_TRAIN-DEV_DEPENDS dev)
set(CPACK_DEBIAN_TRAIN-DEV_PACKAGE_DEPENDS "libeigen3-dev, libglm-dev, libembree-dev, libtinygltf-dev")

set(CPACK_DEBIAN_TOOLS_PACKAGE_SECTION graphics)
set(CPACK_COMPONENT_TOOLS_DESCRIPTION "LSNIF command-line program (lsnif train, eval, render, bench, ...)")
set(CPACK_COMPONENT_TOOLS_DEPENDS runtime)
set(CPACK_DEBIAN_TOOLS_PACKAGE_SHLIBDEPS ON)
# volk opens libvulkan.so.1 at run time (dlopen), which dpkg-shlibdeps cannot see; it adds the rest.
set(CPACK_DEBIAN_TOOLS_PACKAGE_DEPENDS "libvulkan1")
set(CPACK_DEBIAN_TOOLS_PACKAGE_RECOMMENDS "mesa-vulkan-drivers | vulkan-icd")
# dpkg-shlibdeps must find liblsnif_vk.so.0 (needed by bin/lsnif), which no installed package
# provides: it runs in the tools component's staging folder, beside the runtime component's
# (every component is staged before any is packaged). The dependency on liblsnif-vk0 itself is the
# versioned component dependency above.
set(CPACK_DEBIAN_PYTHON_PACKAGE_SECTION python)
set(CPACK_COMPONENT_PYTHON_DESCRIPTION "LSNIF for Python 3: train, query and render from NumPy (import lsnif)")
set(CPACK_COMPONENT_PYTHON_DEPENDS runtime)
set(CPACK_DEBIAN_PYTHON_PACKAGE_SHLIBDEPS ON)
# The extension is built for one Python minor version (its file name says which) and NumPy; volk
# opens libvulkan.so.1 at run time, as the tools' does.
set(CPACK_DEBIAN_PYTHON_PACKAGE_DEPENDS "${LSNIF_PYTHON_VERSION_RANGE}, python3-numpy, libvulkan1")
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS_PRIVATE_DIRS ../runtime${CPACK_PACKAGING_INSTALL_PREFIX}/${CMAKE_INSTALL_LIBDIR})
include(CPack)
