"""``minparam excite --box``: the Cartesian box of the tool point, from the command line's text or an array."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from minparam_cli.api.common import OptionError
from minparam_cli.errors import InputError

if TYPE_CHECKING:
    import numpy as np


def parse_box(text: str) -> np.ndarray:
    """'XMIN:XMAX,YMIN:YMAX,ZMIN:ZMAX' (empty side: free) -> (3, 2) with NaN for free sides."""
    import numpy as np

    parts = text.split(",")
    if len(parts) != 3:
        raise OptionError("--box", f"expected XMIN:XMAX,YMIN:YMAX,ZMIN:ZMAX, got {text!r}")
    out = np.full((3, 2), np.nan)
    for c, part in enumerate(parts):
        sides = part.split(":")
        if len(sides) != 2:
            raise OptionError("--box", f"expected MIN:MAX for axis {'xyz'[c]}, got {part!r}")
        for k, v in enumerate(sides):
            if v.strip():
                try:
                    out[c, k] = float(v)
                except ValueError:
                    raise OptionError("--box", f"expected a number, got {v!r}") from None
                if not np.isfinite(out[c, k]):
                    raise OptionError("--box", f"expected a finite number, got {v!r}")
        if np.isfinite(out[c]).all() and not out[c, 0] < out[c, 1]:
            raise InputError(f"infeasible limits: --box axis {'xyz'[c]} is empty ({out[c, 0]:g} >= {out[c, 1]:g})")
    if not np.isfinite(out).any():
        raise OptionError("--box", "every side is free")
    return out


def box_option(box: Any) -> np.ndarray | None:
    """The box from the CLI's text or from a (3, 2) array-like (None or NaN: a free side)."""
    import numpy as np

    if box is None:
        return None
    if isinstance(box, str):
        return parse_box(box)
    try:
        arr = np.array([[np.nan if v is None else float(v) for v in row] for row in box], dtype=float)
    except (TypeError, ValueError):
        raise OptionError("--box", f"expected (3, 2) bounds [[XMIN, XMAX], [YMIN, YMAX], [ZMIN, ZMAX]], got {box!r}") from None
    if arr.shape != (3, 2) or np.isinf(arr).any():
        raise OptionError("--box", f"expected (3, 2) finite bounds [[XMIN, XMAX], [YMIN, YMAX], [ZMIN, ZMAX]], got {box!r}")
    return parse_box(",".join(":".join("" if np.isnan(v) else repr(float(v)) for v in row) for row in arr))
