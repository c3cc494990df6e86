"""Generated code (``minparam codegen``)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path


@dataclass(frozen=True)
class GeneratedCode:
    """Generated code (``minparam codegen``): ``files`` maps a suffix (".c", ".h"; ".py") to the text
    the command writes, ``counts`` the operations of each generated function ({"mul", "add", "sin",
    ...}), ``base_names`` the columns of the base regressor (derive's base set).  ``write(path)``
    writes the file(s) as ``-o path`` does (C: path.c and path.h)."""

    lang: str
    files: dict[str, str] = field(repr=False)
    counts: dict[str, dict[str, int]] = field(repr=False)
    base_names: tuple[str, ...]
    output: Path | None = None
    notes: tuple[str, ...] = ()
    _generated_stem: str = field(default="", repr=False)  # the C source includes <stem>.h

    @property
    def source(self) -> str:
        """The main file: the .c source for C, the module for python and casadi."""
        return self.files[".c"] if self.lang == "c" else self.files[".py"]

    @property
    def header(self) -> str | None:
        """The C header (None for python and casadi)."""
        return self.files.get(".h")

    def write(self, path: str | Path | None = None) -> list[Path]:
        """Write the file(s) atomically to ``path`` (default: the ``output`` the code was generated for);
        for C, ``path`` names the .c file and the .h goes beside it.  Returns the paths written."""
        from minparam_cli.errors import InputError
        from minparam_cli.output import is_stdout, write_code_files

        target = Path(path) if path is not None else self.output
        if target is None:
            raise InputError("write: give a path (the code was generated without an output)")
        if self.lang == "c":
            stem = self._generated_stem
            if is_stdout(target):
                raise InputError("C output is two files (.c and .h): give a path FILE.c")
            if target.stem != stem:
                raise InputError(f"write: the C source includes {stem}.h; write it as {stem}.c (or generate with output={str(target)!r})")
        return write_code_files(self.files, self.lang, target)
