# Installs the build tree into WORK_DIR/prefix, then configures, builds and runs
# tests/install_consumer against it with find_package(indicial). cmake -P script (ctest).
file(REMOVE_RECURSE ${WORK_DIR})
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
  message(STATUS "${out}")
endfunction()
run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/prefix)
run(${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${WORK_DIR}/build -G ${GENERATOR}
    -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix -DCMAKE_BUILD_TYPE=Release
    "-DCMAKE_EXE_LINKER_FLAGS=${LINKER_FLAGS}")
run(${CMAKE_COMMAND} --build ${WORK_DIR}/build)
run(${WORK_DIR}/build/consumer_cpp)
get_filename_component(examples ${SOURCE_DIR}/../../examples ABSOLUTE)
run(${WORK_DIR}/build/consumer_c ${examples}/synthetic-lift-moment.coef)

# A C-only project (LANGUAGES C): the static library links without the C++ linker, and the
# shared one as it is.
run(${CMAKE_COMMAND} -S ${SOURCE_DIR}/../install_consumer_c -B ${WORK_DIR}/build_c -G ${GENERATOR}
    -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix -DCMAKE_BUILD_TYPE=Release
    "-DCMAKE_EXE_LINKER_FLAGS=${LINKER_FLAGS}")
run(${CMAKE_COMMAND} --build ${WORK_DIR}/build_c)
run(${WORK_DIR}/build_c/consumer_c_static ${examples}/synthetic-lift-moment.coef)
run(${WORK_DIR}/build_c/consumer_c_shared ${examples}/synthetic-lift-moment.coef)
file(GLOB so ${WORK_DIR}/prefix/lib*/libindicial_c.so)
if(NOT so)
  message(FATAL_ERROR "libindicial_c.so was not installed")
endif()
# It exports the C interface only (runtime/src/indicial_c.map), not the runtime's C++ template
# instances.
find_program(NM nm)
if(NM)
  execute_process(COMMAND ${NM} -D --defined-only ${so} OUTPUT_VARIABLE symbols RESULT_VARIABLE rc)
  string(REGEX MATCHALL "[^\n]+" lines "${symbols}")
  list(LENGTH lines count)
  if(NOT rc EQUAL 0 OR count LESS 10)
    message(FATAL_ERROR "nm -D ${so} failed or listed too few symbols (${count}):\n${symbols}")
  endif()
  foreach(line ${lines})
    if(NOT line MATCHES " indicial_[a-z0-9_]+$")
      message(FATAL_ERROR "libindicial_c.so exports more than the C interface: ${line}")
    endif()
  endforeach()
  message(STATUS "libindicial_c.so exports ${count} symbols, all indicial_*")
endif()
# Python ctypes loads the installed shared library and reads a model through it. Not in a
# sanitizer build: a library built with -fsanitize=address cannot be loaded into an
# interpreter that was not started with the ASan runtime ("ASan runtime does not come first").
find_program(PYTHON3 python3)
if(PYTHON3 AND NOT LINKER_FLAGS MATCHES "sanitize")
  run(${PYTHON3} -c "import ctypes, sys
lib = ctypes.CDLL(sys.argv[1])
lib.indicial_model_bytes.restype = ctypes.c_size_t
model = ctypes.create_string_buffer(lib.indicial_model_bytes())
text = open(sys.argv[2], 'rb').read()
err = ctypes.create_string_buffer(128)
rc = lib.indicial_model_load(model, text, ctypes.c_size_t(len(text)), err, ctypes.c_size_t(128))
assert rc == 0, err.value
lib.indicial_model_outputs.argtypes = [ctypes.c_void_p]
print('ctypes:', lib.indicial_model_outputs(model), 'outputs')
assert lib.indicial_model_outputs(model) == 2" ${so} ${examples}/synthetic-lift-moment.coef)
endif()
