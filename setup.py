"""Build of the one optional C extension; everything else is in pyproject.toml.

``exoleg.dynamics._onecall`` calls the compiled kernels on one state with little
overhead (see ``src/exoleg/dynamics/single.py``). It is optional: without a C
compiler the build goes on without it and exoleg uses its general path.
"""

import numpy
from setuptools import Extension, setup

setup(ext_modules=[Extension(
    "exoleg.dynamics._onecall", ["src/exoleg/dynamics/_onecall.c"],
    include_dirs=[numpy.get_include()], optional=True,
    define_macros=[("NPY_NO_DEPRECATED_API", "NPY_1_7_API_VERSION")])])
