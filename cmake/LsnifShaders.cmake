# lsnif_spirv_header(OUTPUT header NAME symbol SOURCE shader [DEFINES -D...] [INCLUDES dir...]
#                    [DEPENDS file...] [HLSL_STAGE stage]): compiles one GLSL shader (glslangValidator,
# Vulkan 1.2; with HLSL_STAGE an HLSL one of that stage, entry main, Vulkan 1.1: glslang 12 writes
# HLSL storage buffers with a decoration SPIR-V 1.4+ no longer has) at
# build time into a header that defines `const uint32_t symbol[]`, so that programs carry their
# SPIR-V instead of reading it from the build tree. Shaders include by path from the one source root
# (`#include "lsnif/shaders/lsnif_walk.glsl"`), which is always on the include path; the SDK's GLSL
# (src/lsnif/*.glsl, *.h and src/lsnif/shaders/) is always a dependency.
find_program(LSNIF_GLSLANG_VALIDATOR glslangValidator REQUIRED)
set(LSNIF_SHARED_SHADER_DIR ${CMAKE_CURRENT_LIST_DIR}/../src)
file(GLOB LSNIF_SHARED_SHADER_INCLUDES CONFIGURE_DEPENDS ${LSNIF_SHARED_SHADER_DIR}/lsnif/*.glsl
  ${LSNIF_SHARED_SHADER_DIR}/lsnif/*.hlsl ${LSNIF_SHARED_SHADER_DIR}/lsnif/*.h
  ${LSNIF_SHARED_SHADER_DIR}/lsnif/shaders/*.glsl)
function(lsnif_spirv_header)
  cmake_parse_arguments(A "" "OUTPUT;NAME;SOURCE;HLSL_STAGE" "DEFINES;INCLUDES;DEPENDS" ${ARGN})
  get_filename_component(dir ${A_OUTPUT} DIRECTORY)
  get_filename_component(name ${A_SOURCE} NAME)
  set(includes -I${LSNIF_SHARED_SHADER_DIR})
  foreach(inc ${A_INCLUDES})
    list(APPEND includes -I${inc})
  endforeach()
  set(language --target-env vulkan1.2)
  if(A_HLSL_STAGE)
    set(language -D -S ${A_HLSL_STAGE} -e main --target-env vulkan1.1)
  endif()
  add_custom_command(OUTPUT ${A_OUTPUT}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${dir}
    COMMAND ${LSNIF_GLSLANG_VALIDATOR} ${language} -V ${A_DEFINES} ${includes} --vn ${A_NAME}
            ${A_SOURCE} -o ${A_OUTPUT}
    DEPENDS ${A_SOURCE} ${LSNIF_SHARED_SHADER_INCLUDES} ${A_DEPENDS}
    COMMENT "glslangValidator ${name} -> ${A_NAME}" VERBATIM)
endfunction()
