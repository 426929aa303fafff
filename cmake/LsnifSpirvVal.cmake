# cmake -DSPIRV_VAL=spirv-val "-DFILES=a.spv;b.spv" -P LsnifSpirvVal.cmake: runs spirv-val (Vulkan
# 1.2 rules) on each file; fails naming the first file it rejects, or a file that is missing.
foreach(f ${FILES})
  if(NOT EXISTS ${f})
    message(FATAL_ERROR "${f} does not exist (build the target lsnif_coopmat_spv)")
  endif()
  execute_process(COMMAND ${SPIRV_VAL} --target-env vulkan1.2 ${f} RESULT_VARIABLE rc OUTPUT_VARIABLE out
    ERROR_VARIABLE out)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "spirv-val rejected ${f}:\n${out}")
  endif()
  message(STATUS "spirv-val: ${f} valid")
endforeach()
