# check_layers_selftest.cmake -- proves tests/check_layers.cmake can fail (ctest
# fitter_layers_selftest). Plants a small fitter tree in WORK_DIR with one clean file and one
# of each violation, runs the checker on it, and fails unless the checker exits non-zero and
# names every planted violation (and not the clean file).
#
#   cmake -DCHECKER=tests/check_layers.cmake -DWORK_DIR=<scratch> -P tests/check_layers_selftest.cmake
cmake_minimum_required(VERSION 3.20)
foreach(v CHECKER WORK_DIR)
  if(NOT DEFINED ${v})
    message(FATAL_ERROR "check_layers_selftest.cmake: pass -D${v}=...")
  endif()
endforeach()

set(root ${WORK_DIR}/planted)
file(REMOVE_RECURSE ${root})
set(src ${root}/fitter/src)
set(inc ${root}/fitter/include/indicial/fitter)

# Clean: a report file including a lower layer publicly and privately, with ; and [ ] in code.
file(WRITE ${src}/report/clean.cpp
"#include \"indicial/fitter/report.hpp\"\n#include \"estimate/fit_internal.hpp\"\n#include <vector>\nint a[2] = {1, 2}; // ;\n")
file(WRITE ${src}/estimate/fit_internal.hpp "#include \"indicial/fitter/fit.hpp\"\n")
file(WRITE ${inc}/report.hpp "#include \"indicial/fitter/fit.hpp\"\n")
file(WRITE ${inc}/fit.hpp "#pragma once\n")
file(WRITE ${inc}/diagnose.hpp "#include \"indicial/fitter/report.hpp\"\n")
# Violations, each on a known line.
file(WRITE ${src}/report/upward.cpp "// line 1\n#include \"indicial/fitter/diagnose.hpp\"\n")
file(WRITE ${src}/numerics/private_upward.cpp "int x; // [\n#include <vector>\n#include \"estimate/fit_internal.hpp\"\n")
file(WRITE ${src}/estimate/sibling.cpp "#include <indicial/fitter/simulate.hpp>\n")
file(WRITE ${inc}/simulate.hpp "#pragma once\n")
file(WRITE ${src}/diagnose/relative.cpp "#include \"../estimate/fit_internal.hpp\"\n#include \"fit_internal.hpp\"\n")
file(WRITE ${src}/loose.cpp "int y;\n")
file(WRITE ${src}/gui/widget.cpp "int z;\n")
file(WRITE ${inc}/unplaced.hpp "#pragma once\n")
file(WRITE ${root}/tests/test_x.cpp "#include \"../fitter/src/estimate/fit_internal.hpp\"\n")

execute_process(COMMAND ${CMAKE_COMMAND} -DFITTER_DIR=${root}/fitter -DEXTRA_DIRS=${root}/tests
                        -P ${CHECKER}
                RESULT_VARIABLE result OUTPUT_VARIABLE out ERROR_VARIABLE err)
set(log "${out}${err}")
if(result EQUAL 0)
  message(FATAL_ERROR "the checker passed a tree with planted violations:\n${log}")
endif()
set(expected
  "report/upward.cpp:2: \"indicial/fitter/diagnose.hpp\": layer report may not include layer diagnose"
  "numerics/private_upward.cpp:3: \"estimate/fit_internal.hpp\": layer numerics may not include layer estimate"
  "estimate/sibling.cpp:1: \"indicial/fitter/simulate.hpp\": layer estimate may not include layer simulate"
  "diagnose/relative.cpp:1: \"../estimate/fit_internal.hpp\": include fitter headers by layer path"
  "diagnose/relative.cpp:2: \"fit_internal.hpp\": include fitter headers by layer path"
  "src/loose.cpp: not in a layer folder"
  "src/gui/widget.cpp: folder 'gui' is not a layer"
  "unplaced.hpp: public header without a layer"
  "test_x.cpp: #include \"../fitter/src/estimate/fit_internal.hpp\": include private fitter headers by layer path"
  "check_layers: 9 include(s) against the fitter's layers")
foreach(e IN LISTS expected)
  string(FIND "${log}" "${e}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "the checker did not report: ${e}\nits output:\n${log}")
  endif()
endforeach()
if(log MATCHES "clean\\.cpp" OR log MATCHES "fit_internal\\.hpp:[0-9]")
  message(FATAL_ERROR "the checker reported a clean file:\n${log}")
endif()
message(STATUS "check_layers reported all 9 planted violations and nothing else")
