# check_mixup.cmake -- a model handle and a state handle swapped must not compile (ctest
# c_handles_mixup_refused). Compiles handles_mixup.c with the build's C compiler (C99,
# -Werror=incompatible-pointer-types: the diagnostic C compilers give a swapped pointer type,
# an error by default since GCC 14) and C++ compiler; each must refuse the swapped call with a
# pointer-type diagnostic and accept the same call in the right order.
#
#   cmake -DC_COMPILER=cc -DCXX_COMPILER=c++ -DINCLUDE_DIR=runtime/include -DSOURCE=handles_mixup.c
#         -P check_mixup.cmake
cmake_minimum_required(VERSION 3.20)
foreach(v C_COMPILER CXX_COMPILER INCLUDE_DIR SOURCE)
  if(NOT DEFINED ${v})
    message(FATAL_ERROR "check_mixup.cmake: pass -D${v}=...")
  endif()
endforeach()

function(try_compile_source label compiler flags expect)
  foreach(variant fixed mixed)
    set(defines "")
    if(variant STREQUAL "fixed")
      set(defines -DINDICIAL_MIXUP_FIXED)
    endif()
    execute_process(COMMAND ${compiler} ${flags} ${defines} -fsyntax-only -I${INCLUDE_DIR} ${SOURCE}
                    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
    if(variant STREQUAL "fixed" AND NOT rc EQUAL 0)
      message(FATAL_ERROR "${label}: the call in the right order does not compile:\n${out}${err}")
    endif()
    if(variant STREQUAL "mixed")
      if(rc EQUAL 0)
        message(FATAL_ERROR "${label}: swapped model and state handles compiled")
      endif()
      if(NOT "${out}${err}" MATCHES "${expect}")
        message(FATAL_ERROR "${label}: refused, but not for the handle types:\n${out}${err}")
      endif()
    endif()
  endforeach()
  message(STATUS "${label}: swapped handles refused, the right order accepted")
endfunction()

try_compile_source("C99" ${C_COMPILER} "-std=c99;-Werror=incompatible-pointer-types"
                   "incompatible pointer type")
try_compile_source("C++" ${CXX_COMPILER} "-x;c++;-std=c++17"
                   "cannot convert")
