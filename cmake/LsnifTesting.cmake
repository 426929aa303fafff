# lsnif_add_tests_per_file(PREFIX p LIBS ... [DEFINES ...] [TEST_PREFIX t] [LABEL l]): one GoogleTest
# executable p<name> per *_test.cpp of the calling folder, linked with LIBS, compiled with DEFINES
# and LSNIF_DATA_DIR, its tests discovered with label l (default "host") and CTest names prefixed
# by t. Each module's tests build and fail alone. Files named *_fuzz_test.cpp hold mutation campaigns,
# the longest unit tests: their COST makes CTest start them first when it has no timings of its own.
# Files named *_training_test.cpp train models to measure what they learn (label `training` instead
# of l): seconds in an optimized build, minutes under the sanitizers, whose pass leaves them out as
# it leaves out the end-to-end tests (.ci/run).
function(lsnif_add_tests_per_file)
  cmake_parse_arguments(ARG "" "PREFIX;TEST_PREFIX;LABEL" "LIBS;DEFINES" ${ARGN})
  if(NOT ARG_LABEL)
    set(ARG_LABEL host)
  endif()
  file(GLOB tests CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*_test.cpp)
  foreach(src ${tests})
    get_filename_component(name ${src} NAME_WE)
    set(exe ${ARG_PREFIX}${name})
    add_executable(${exe} ${src})
    target_link_libraries(${exe} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gtest_main lsnif_warnings lsnif_test_code)
    target_compile_definitions(${exe} PRIVATE LSNIF_DATA_DIR="${LSNIF_DATA_DIR}" ${ARG_DEFINES})
    set(cost 0)
    set(label ${ARG_LABEL})
    if(name MATCHES "_fuzz_test$")
      set(cost 60)
    elseif(name MATCHES "_training_test$")
      set(cost 30)
      set(label training)
    endif()
    gtest_discover_tests(${exe} DISCOVERY_TIMEOUT 60 TEST_PREFIX "${ARG_TEST_PREFIX}"
      PROPERTIES LABELS ${label} COST ${cost})
  endforeach()
endfunction()
