# check_layers.cmake -- the fitter's include directions (docs/architecture.md, "The fitter's
# layers"), checked over the source tree. Run by ctest (test fitter_layers):
#
#   cmake -DFITTER_DIR=<repo>/fitter [-DEXTRA_DIRS="<repo>/tests;<repo>/bench;<repo>/tools"]
#         -P tests/check_layers.cmake
#
# Exits non-zero and prints one line per violation (file:line: problem). A violation is
#   * a file directly in fitter/src or in a folder that is not a layer (it would not be built:
#     fitter/CMakeLists.txt globs the layer folders only),
#   * an #include of a fitter header from a layer the including file's layer may not use,
#   * a private header included by a relative path ("../x.hpp", "fit_internal.hpp") rather
#     than by layer path ("estimate/fit_internal.hpp"),
#   * a public header (fitter/include/indicial/fitter/*.hpp) without a layer in the table below,
#   * in EXTRA_DIRS (tests, benchmarks, tools): an #include that reaches into fitter/src by a
#     relative path (they include private headers by layer path through indicial::fitter_internal).
# tests/check_layers_selftest.cmake plants violations in a scratch tree and expects each one
# reported, so this check is known to fail when it should.
#
# Written by hand (a CMake script, no dependency beyond CMake): include-what-you-use and
# clang-tidy check includes, not a project's own layer order.
cmake_minimum_required(VERSION 3.20)

if(NOT DEFINED FITTER_DIR)
  message(FATAL_ERROR "check_layers.cmake: pass -DFITTER_DIR=<repo>/fitter")
endif()

# The layers, lowest first, and the layers each may include (besides itself). Keep in step with
# docs/architecture.md. Every layer may include shared/ and runtime/ (indicial/*.hpp).
set(LAYERS numerics io estimate simulate predict report diagnose studies)
string(JOIN " " LAYER_NAMES ${LAYERS})
set(ALLOWED_numerics "")
set(ALLOWED_io numerics)
set(ALLOWED_estimate numerics io)
set(ALLOWED_simulate numerics io)
set(ALLOWED_predict numerics io)
set(ALLOWED_report numerics io estimate simulate predict)
set(ALLOWED_diagnose numerics io estimate simulate predict report)
set(ALLOWED_studies numerics io estimate simulate predict report diagnose)

# The layer of each public header (fitter/include/indicial/fitter/NAME.hpp). version.hpp is
# generated into the build tree (cmake/version.cmake) and belongs to io (provenance).
set(PUBLIC_derivative numerics)
set(PUBLIC_error io)
set(PUBLIC_experiment io)
set(PUBLIC_experiment_toml io)
set(PUBLIC_csv_reader io)
set(PUBLIC_phase_resample io)
set(PUBLIC_did_you_mean io)
set(PUBLIC_io io)
set(PUBLIC_output io)
set(PUBLIC_gnuplot io)
set(PUBLIC_provenance io)
set(PUBLIC_version io)
set(PUBLIC_model_merge io)
set(PUBLIC_runtime_limits io)
set(PUBLIC_experiment_checks io)
set(PUBLIC_fit estimate)
set(PUBLIC_noise_level estimate)
set(PUBLIC_replication estimate)
set(PUBLIC_quasi_static_polar estimate)
set(PUBLIC_simulate simulate)
set(PUBLIC_tailless_model simulate)
set(PUBLIC_dynamic_stall simulate)
set(PUBLIC_predict predict)
set(PUBLIC_prediction_output predict)
set(PUBLIC_freqresp predict)
set(PUBLIC_freqresp_output predict)
set(PUBLIC_report report)
set(PUBLIC_diagnose diagnose)
set(PUBLIC_montecarlo studies)
set(PUBLIC_validation_realistic studies)

set(violations "")
macro(violation text)
  list(APPEND violations "${text}")
endmacro()

# The layer an included path belongs to, or "" for a header outside the fitter (shared/,
# runtime/, system), or "?relative" / "?unknown:<name>" for an include that breaks the rules.
function(included_layer path out)
  if(path MATCHES "^indicial/fitter/([A-Za-z0-9_]+)\\.hpp$")
    set(name ${CMAKE_MATCH_1})
    if(DEFINED PUBLIC_${name})
      set(${out} ${PUBLIC_${name}} PARENT_SCOPE)
    else()
      set(${out} "?unknown:${name}" PARENT_SCOPE)
    endif()
  elseif(path MATCHES "^indicial/")
    set(${out} "" PARENT_SCOPE)
  elseif(path MATCHES "^([a-z]+)/")
    if(CMAKE_MATCH_1 IN_LIST LAYERS)
      set(${out} ${CMAKE_MATCH_1} PARENT_SCOPE)
    else()
      set(${out} "?relative" PARENT_SCOPE)
    endif()
  else()
    set(${out} "?relative" PARENT_SCOPE)
  endif()
endfunction()

# Checks the quoted and fitter-angled #include lines of one file of layer `layer`.
function(check_file file layer)
  # One list element per line: the characters CMake's list syntax would read (; [ ] \) are
  # replaced first, so line numbers stay exact.
  file(READ ${file} text)
  string(REGEX REPLACE "[][;\\]" "_" text "${text}")
  string(REPLACE "\n" ";" lines "${text}")
  set(found "")
  set(n 0)
  foreach(line IN LISTS lines)
    math(EXPR n "${n} + 1")
    if(NOT line MATCHES "^[ \t]*#[ \t]*include[ \t]*([\"<])([^\">]+)[\">]")
      continue()
    endif()
    set(delim "${CMAKE_MATCH_1}")
    set(path "${CMAKE_MATCH_2}")
    if(delim STREQUAL "<" AND NOT path MATCHES "^indicial/fitter/")
      continue()  # system and library headers
    endif()
    included_layer("${path}" to)
    if(to STREQUAL "")
      continue()
    elseif(to STREQUAL "?relative")
      list(APPEND found "${file}:${n}: \"${path}\": include fitter headers by layer path (e.g. \"estimate/fit_internal.hpp\") or as \"indicial/fitter/...\", never relative")
    elseif(to MATCHES "^\\?unknown:(.*)")
      list(APPEND found "${file}:${n}: \"${path}\": public header without a layer (add it to tests/check_layers.cmake and docs/architecture.md)")
    elseif(NOT to STREQUAL layer AND NOT to IN_LIST ALLOWED_${layer})
      list(APPEND found "${file}:${n}: \"${path}\": layer ${layer} may not include layer ${to} (docs/architecture.md)")
    endif()
  endforeach()
  set(file_violations "${found}" PARENT_SCOPE)
endfunction()

# 1. Every source file of fitter/src in a layer folder.
file(GLOB_RECURSE sources RELATIVE ${FITTER_DIR}/src ${FITTER_DIR}/src/*)
foreach(rel IN LISTS sources)
  if(NOT rel MATCHES "^([^/]+)/")
    violation("${FITTER_DIR}/src/${rel}: not in a layer folder (${LAYER_NAMES})")
    continue()
  endif()
  set(layer ${CMAKE_MATCH_1})
  if(NOT layer IN_LIST LAYERS)
    violation("${FITTER_DIR}/src/${rel}: folder '${layer}' is not a layer (${LAYER_NAMES})")
    continue()
  endif()
  if(rel MATCHES "\\.(cpp|hpp|h)$")
    check_file(${FITTER_DIR}/src/${rel} ${layer})
    list(APPEND violations ${file_violations})
  endif()
endforeach()

# 2. Every public header has a layer and includes only what its layer may.
file(GLOB headers ${FITTER_DIR}/include/indicial/fitter/*.hpp)
foreach(h IN LISTS headers)
  get_filename_component(name ${h} NAME_WE)
  if(NOT DEFINED PUBLIC_${name})
    violation("${h}: public header without a layer (add it to tests/check_layers.cmake and docs/architecture.md)")
    continue()
  endif()
  check_file(${h} ${PUBLIC_${name}})
  list(APPEND violations ${file_violations})
endforeach()

# 3. Tests, benchmarks and tools never reach into fitter/src by a relative path.
foreach(dir IN LISTS EXTRA_DIRS)
  file(GLOB_RECURSE extra ${dir}/*.cpp ${dir}/*.hpp ${dir}/*.h ${dir}/*.c)
  foreach(f IN LISTS extra)
    file(STRINGS ${f} lines REGEX "^[ \t]*#[ \t]*include[ \t]*\"[^\"]*\\.\\./[^\"]*fitter/src")
    foreach(line IN LISTS lines)
      violation("${f}: ${line}: include private fitter headers by layer path through indicial::fitter_internal, not relative")
    endforeach()
  endforeach()
endforeach()

list(LENGTH violations count)
if(count GREATER 0)
  foreach(v IN LISTS violations)
    message("${v}")
  endforeach()
  message(FATAL_ERROR "check_layers: ${count} include(s) against the fitter's layers")
endif()
message(STATUS "check_layers: fitter/src and its public headers follow the layer directions")
