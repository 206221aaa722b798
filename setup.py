"""The kernels compiled ahead of time (Cython -> C, with the machine's C compiler): pip,
``make`` and the wheel build them; the rest of the build is pyproject.toml's."""

import os

from Cython.Build import cythonize
from setuptools import Extension, setup

KERNELS = ["granavg/io/_parse.pyx", "granavg/engine/_checks.pyx", "granavg/engine/_weights.pyx",
           "granavg/engine/_sphere_weights.pyx", "granavg/engine/_sums.pyx",
           "granavg/engine/cells/_sectors.pyx", "granavg/sim/_contact_state.pyx",
           "granavg/engine/smoothing/_kernels.pyx"]

setup(ext_modules=cythonize(
    [Extension(path[:-4].replace("/", "."), [path], extra_compile_args=["-O3"])
     for path in KERNELS],
    compiler_directives={"language_level": 3}, quiet=True, nthreads=os.cpu_count() or 1),
    # the C files compiled side by side, one per core
    options={"build_ext": {"parallel": os.cpu_count() or 1}})
