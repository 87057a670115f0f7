"""Builds the Python package trainsim from the source tree with the shared library
inside it (pyproject.toml says how to call it). The library is, in order: the file
named by TRAINSIM_LIBRARY; build/libtrainsim_c.so (bash scripts/setup.sh made it);
else CMake builds the target trainsim_c into build-python/ (Release, no tests)."""
import os
import shutil
import subprocess

from setuptools import setup
from setuptools.command.build_py import build_py

ROOT = os.path.dirname(os.path.abspath(__file__))


def find_library():
    env = os.environ.get("TRAINSIM_LIBRARY")
    if env:
        if not os.path.isfile(env):
            raise SystemExit(f"setup.py: TRAINSIM_LIBRARY={env} is not a file")
        return env
    built = os.path.join(ROOT, "build", "libtrainsim_c.so")
    if os.path.isfile(built):
        return built
    where = os.path.join(ROOT, "build-python")
    print(f"setup.py: no {built}: building libtrainsim_c with CMake in {where}", flush=True)
    subprocess.run(["cmake", "-S", ROOT, "-B", where, "-DCMAKE_BUILD_TYPE=Release", "-DBUILD_TESTING=OFF",
                    "-DTRAINSIM_BUILD_BENCHMARKS=OFF"], check=True)
    subprocess.run(["cmake", "--build", where, "--target", "trainsim_c", "--parallel", "2"], check=True)
    return os.path.join(where, "libtrainsim_c.so")


class BuildWithLibrary(build_py):
    def run(self):
        super().run()
        lib = find_library()
        target = os.path.join(self.build_lib, "trainsim", "libtrainsim_c.so")
        print(f"setup.py: bundling {os.path.realpath(lib)} as {target}", flush=True)
        shutil.copyfile(os.path.realpath(lib), target)


setup(cmdclass={"build_py": BuildWithLibrary},
      options={"build": {"build_base": os.path.join("build-python", "setuptools")},
               "egg_info": {"egg_base": os.path.join("build-python")}})
