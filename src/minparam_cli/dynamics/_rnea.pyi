"""Types of the compiled regressor kernel (``_rnea.c``, built by setup.py when a C compiler is present).

Every array is a buffer of the layout ``regressor._kernel_arrays`` makes (float64, C-contiguous;
``parents``, ``revolute`` and ``dest`` of their own integer types); ``out`` is written in place."""

import numpy as np

def inertial_regressor(
    out: np.ndarray, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, terms: np.ndarray, axor: np.ndarray,
    parents: np.ndarray, revolute: np.ndarray, gravity: np.ndarray, N: int, n: int, P: int, lanes: int = ..., /,
) -> None: ...
def inertial_columns(
    out: np.ndarray, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, terms: np.ndarray, axor: np.ndarray,
    parents: np.ndarray, revolute: np.ndarray, gravity: np.ndarray, dest: np.ndarray, N: int, n: int,
    joint_stride: int, row_stride: int, lanes: int = ..., /,
) -> None: ...
def lane_widths() -> list[int]: ...
