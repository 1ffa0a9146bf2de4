"""Builds the extension digilap._digilap with the project's own CMake (pyproject.toml says how to
call pip). CMake finds Eigen, Spectra, pybind11 and nifticlib from Debian's packages; nothing is
downloaded. DIGILAP_BUILD_DIR reuses a CMake build directory (default: build/pip)."""
import glob
import os
import shutil
import subprocess

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = os.path.dirname(os.path.abspath(__file__))


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        build_dir = os.environ.get("DIGILAP_BUILD_DIR", os.path.join(ROOT, "build", "pip"))
        if not os.path.isabs(build_dir):
            build_dir = os.path.join(ROOT, build_dir)
        configure = ["cmake", "-S", ROOT, "-B", build_dir, "-DCMAKE_BUILD_TYPE=Release", "-DDIGILAP_PYTHON=ON"]
        subprocess.check_call(configure, stdout=subprocess.DEVNULL)
        subprocess.check_call(["cmake", "--build", build_dir, "--target", "_digilap", "-j", str(os.cpu_count() or 1)])
        built = glob.glob(os.path.join(build_dir, "python", "digilap", "_digilap*.so"))
        if not built:
            raise RuntimeError("the CMake build made no _digilap module in " + build_dir)
        target = self.get_ext_fullpath(ext.name)
        os.makedirs(os.path.dirname(target), exist_ok=True)
        shutil.copyfile(built[0], target)


setup(
    packages=["digilap"],
    package_dir={"": "python"},
    ext_modules=[Extension("digilap._digilap", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
)
