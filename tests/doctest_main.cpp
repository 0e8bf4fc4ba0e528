// The doctest runner, compiled once and linked into every test executable (except the
// -fno-exceptions one, which defines its own): saves compiling doctest's implementation in
// each of the ~40 test files.
#define DOCTEST_CONFIG_IMPLEMENT_WITH_MAIN
#include <doctest/doctest.h>
