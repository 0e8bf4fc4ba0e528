// The git commit `indicial` was built from (generated header: cmake/version.cmake). Kept out
// of the unity build and the fitter library so that a new commit recompiles this file only.
#include "command.hpp"
#include "indicial/fitter/commit.hpp"

namespace indicial::tools {

const char* build_commit() { return INDICIAL_COMMIT; }

}  // namespace indicial::tools
