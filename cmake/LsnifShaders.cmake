# lsnif_spirv_header(OUTPUT header NAME symbol SOURCE shader [DEFINES -D...] [INCLUDES dir...]
#                    [DEPENDS file...]): compiles one GLSL shader (glslangValidator, Vulkan 1.2) at
# build time into a header that defines `const uint32_t symbol[]`, so that programs carry their
# SPIR-V instead of reading it from the build tree. Shaders include by path from the one source root
# (`#include "lsnif/shaders/lsnif_walk.glsl"`), which is always on the include path; the SDK's GLSL
# (src/lsnif/*.glsl, *.h and src/lsnif/shaders/) is always a dependency.
find_program(LSNIF_GLSLANG_VALIDATOR glslangValidator REQUIRED)
set(LSNIF_SHARED_SHADER_DIR ${CMAKE_CURRENT_LIST_DIR}/../src)
file(GLOB LSNIF_SHARED_SHADER_INCLUDES CONFIGURE_DEPENDS ${LSNIF_SHARED_SHADER_DIR}/lsnif/*.glsl
  ${LSNIF_SHARED_SHADER_DIR}/lsnif/*.h ${LSNIF_SHARED_SHADER_DIR}/lsnif/shaders/*.glsl)
function(lsnif_spirv_header)
  cmake_parse_arguments(A "" "OUTPUT;NAME;SOURCE" "DEFINES;INCLUDES;DEPENDS" ${ARGN})
  get_filename_component(dir ${A_OUTPUT} DIRECTORY)
  get_filename_component(name ${A_SOURCE} NAME)
  set(includes -I${LSNIF_SHARED_SHADER_DIR})
  foreach(inc ${A_INCLUDES})
    list(APPEND includes -I${inc})
  endforeach()
  add_custom_command(OUTPUT ${A_OUTPUT}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${dir}
    COMMAND ${LSNIF_GLSLANG_VALIDATOR} --target-env vulkan1.2 -V ${A_DEFINES} ${includes} --vn ${A_NAME}
            ${A_SOURCE} -o ${A_OUTPUT}
    DEPENDS ${A_SOURCE} ${LSNIF_SHARED_SHADER_INCLUDES} ${A_DEPENDS}
    COMMENT "glslangValidator ${name} -> ${A_NAME}" VERBATIM)
endfunction()
