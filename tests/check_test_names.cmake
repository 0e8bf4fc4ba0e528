# ctest `test_case_names`: refuses a doctest TEST_CASE name that ctest cannot run.
# doctest_discover_tests turns each TEST_CASE into a ctest test named after it, and CMake
# splits a name at ';' into a list: the halves match no test case, so doctest runs nothing and
# the "test" passes in 0.04 s (found after a failing case had been hidden that way).
# Usage: cmake -DSOURCE_DIR=<tests dir> -P check_test_names.cmake
file(GLOB sources "${SOURCE_DIR}/test_*.cpp")
set(bad "")
foreach(src ${sources})
  file(STRINGS "${src}" lines REGEX "TEST_CASE\\(\"")
  foreach(line IN LISTS lines)
    if(line MATCHES "TEST_CASE\\(\"[^\"]*;")
      get_filename_component(name "${src}" NAME)
      string(APPEND bad "\n  ${name}: ${line}")
    endif()
  endforeach()
endforeach()
if(NOT bad STREQUAL "")
  message(FATAL_ERROR "TEST_CASE names with ';' (ctest would run nothing for them; use ','):${bad}")
endif()
list(LENGTH sources n_sources)
message(STATUS "no TEST_CASE name has ';' (${n_sources} files)")
