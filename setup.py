"""Build hook for the optional compiled regressor kernel (metadata lives in pyproject.toml).

`optional=True`: without a C compiler the install still succeeds and minparam
uses the numpy regressor, which gives the same numbers (tests/test_kernel.py),
about 13x slower at 100 samples.  That must not pass unnoticed, so a failed
build of the kernel prints a WARNING block: on stderr (shown by `pip install -v`,
`python -m build`, `python setup.py build_ext`), and on the terminal itself
when there is one, because pip shows a build's output only when the build
fails (tests/test_packaging.py).  `minparam --version` names the regressor in
use afterwards.
"""

import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext
from setuptools.errors import BaseError, CCompilerError

WARNING = """
WARNING: minparam's compiled regressor kernel ({name}) was not built:
WARNING:     {reason}
WARNING: minparam is installed and works with its numpy regressor (the same numbers,
WARNING: about 13x slower at 100 samples).  For the kernel, install a C compiler
WARNING: (gcc, clang or MSVC) and reinstall minparam, e.g. `pip install --force-reinstall --no-deps .`
WARNING: `minparam --version` names the regressor in use.
"""


def announce(message: str, tty: str = "/dev/tty") -> None:
    """``message`` on stderr, and on the terminal when there is one (pip hides a build's stderr)."""
    sys.stderr.write(message)
    sys.stderr.flush()
    try:
        with open(tty, "w") as term:
            term.write(message)
    except OSError:  # no controlling terminal (CI, a detached build): stderr only
        pass


class OptionalBuildExt(build_ext):
    """build_ext that says, loudly, when an optional extension could not be built."""

    def build_extension(self, ext):
        try:
            super().build_extension(ext)
        except (CCompilerError, BaseError, OSError) as e:  # no compiler, a failed compile or link
            if not ext.optional:
                raise
            reason = " ".join(str(e).split()) or type(e).__name__
            announce(WARNING.format(name=ext.name, reason=reason))


setup(
    cmdclass={"build_ext": OptionalBuildExt},
    ext_modules=[
        Extension(
            "minparam_cli.dynamics._rnea",
            sources=["src/minparam_cli/dynamics/_rnea.c"],
            depends=["src/minparam_cli/dynamics/_rnea_lanes.h"],  # the loop, included once per lane width
            optional=True,
        )
    ],
)
