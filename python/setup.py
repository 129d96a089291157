"""Builds the module _tether with the project's CMake (the repository is this folder's parent) and packages
it with the pure-Python files of tether/ and the modules and type stubs the CMake build gathers (the codecs'
are in their plugins' folders). Offline: only Debian's setuptools, cmake, g++, pybind11-dev and python3-dev are used.
CMAKE_ARGS (environment) is passed to the configure step, e.g. -DTETHER_NANOPB_SOURCE_DIR=...; the AVR
images are not built here (set TETHER_FIRMWARE_DIR, or install the project with its images, for virtual
boards)."""

import glob
import os
import shlex
import shutil
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

HERE = os.path.dirname(os.path.abspath(__file__))
REPOSITORY = os.path.dirname(HERE)


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        build = os.path.abspath(os.path.join(self.build_temp, "cmake"))
        configure = ["cmake", "-S", REPOSITORY, "-B", build, "-DCMAKE_BUILD_TYPE=Release",
                     f"-DPython_EXECUTABLE={sys.executable}", "-DTETHER_BUILD_PYTHON=ON",
                     "-DTETHER_BUILD_TESTS=OFF", "-DTETHER_BUILD_BENCHMARKS=OFF", "-DTETHER_BUILD_AVR=OFF"]
        configure += shlex.split(os.environ.get("CMAKE_ARGS", ""))
        subprocess.run(configure, check=True)
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL", "2")
        subprocess.run(["cmake", "--build", build, "--target", "_tether", "-j", jobs], check=True)
        built = os.path.join(build, "python", "tether", os.path.basename(self.get_ext_filename(ext.name)))
        target = self.get_ext_fullpath(ext.name)
        os.makedirs(os.path.dirname(target), exist_ok=True)
        shutil.copyfile(built, target)
        # The stubs CMake gathered there: the codecs' (each in its plugin's folder) and the package's, made
        # from tether/__init__.pyi.in; and the modules the codecs ship (their PYTHON_MODULES: tether.compat).
        for part in glob.glob(os.path.join(build, "python", "tether", "*.py*")):
            shutil.copyfile(part, os.path.join(os.path.dirname(target), os.path.basename(part)))


setup(
    packages=["tether"],
    package_data={"tether": ["py.typed", "*.pyi"]},
    ext_modules=[Extension("tether._tether", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
)
