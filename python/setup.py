"""Builds the extension module indicial._indicial with the repository's CMake project.

How the build finds the C++ sources: this package lives in python/ of the indicial
repository, and the module is the CMake target `indicial_python` of the top-level project
(python/CMakeLists.txt), which links the same fitter library and runtime headers the command
line uses. So this script configures ../ (the repository root) in a build directory and builds
that one target; nothing is compiled twice from copied sources. pip builds in the source tree
(pip >= 21.3), so ../ is the repository.

Environment:
  INDICIAL_BUILD_DIR   an existing CMake build directory of the repository (e.g. build, as
                       tools/run-tests.sh makes; a relative path is taken from the repository
                       root, since pip runs this script in python/): the module is built
                       there, reusing its objects, and its configuration is left as it is
  INDICIAL_JOBS        parallel jobs (default: the CPU count)
"""
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

HERE = Path(__file__).resolve().parent
REPO = HERE.parent


def project_version() -> str:
    # The one place the version is spelled: the root CMakeLists.txt's project(VERSION).
    text = (REPO / "CMakeLists.txt").read_text()
    m = re.search(r"project\(indicial VERSION ([0-9.]+)", text)
    if not m:
        raise RuntimeError(f"{REPO / 'CMakeLists.txt'}: no project(indicial VERSION x.y.z)")
    return m.group(1)


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        if not (REPO / "fitter" / "CMakeLists.txt").is_file():
            raise RuntimeError(f"{REPO}: not the indicial repository (python/ must stay inside it)")
        jobs = os.environ.get("INDICIAL_JOBS", str(os.cpu_count() or 1))
        given = os.environ.get("INDICIAL_BUILD_DIR")
        build_dir = (REPO / given).resolve() if given else Path(self.build_temp).resolve() / "cmake"
        if not (build_dir / "CMakeCache.txt").is_file():
            generator = ["-G", "Ninja"] if shutil.which("ninja") else []
            subprocess.run(["cmake", "-S", str(REPO), "-B", str(build_dir), *generator,
                            "-DCMAKE_BUILD_TYPE=Release", "-DINDICIAL_BUILD_TESTS=OFF",
                            "-DINDICIAL_BUILD_BENCH=OFF", "-DINDICIAL_BUILD_PYTHON=ON",
                            f"-DPython3_EXECUTABLE={sys.executable}"], check=True)
        subprocess.run(["cmake", "--build", str(build_dir), "--target", "indicial_python", "-j", jobs], check=True)
        built = sorted((build_dir / "python" / "indicial").glob("_indicial*.so"))
        if not built:
            raise RuntimeError(f"{build_dir}: the build made no python/indicial/_indicial*.so "
                               "(is pybind11-dev installed? see tools/install-deps.sh)")
        target = Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(built[-1], target)


setup(version=project_version(),
      ext_modules=[Extension("indicial._indicial", sources=[])],
      cmdclass={"build_ext": CMakeBuild})
