"""Build hook for the optional compiled regressor kernel (metadata lives in pyproject.toml).

`optional=True`: without a C compiler the install still succeeds and minparam
uses the numpy regressor, which gives the same numbers (tests/test_kernel.py).
"""

from setuptools import Extension, setup

setup(
    ext_modules=[
        Extension(
            "minparam_cli.dynamics._rnea",
            sources=["src/minparam_cli/dynamics/_rnea.c"],
            depends=["src/minparam_cli/dynamics/_rnea_lanes.h"],  # the loop, included once per lane width
            optional=True,
        )
    ]
)
