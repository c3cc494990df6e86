"""The general dodekapod: a free octahedral truss of six nodes and twelve legs (12 DOF).

Inverse kinematics is the twelve edge lengths of the node coordinates.  For
the forward problem the six rigid-motion freedoms are removed by a face
(a, b, c) of the octahedron: a at the origin, b on +x, c in the xy-plane with
y > 0.  The three remaining nodes are the nodes opposite a, b and c, each
joined to the two others of the face, so the problem is exactly the
octahedral 3-3 problem of ``platform_exact``, solved completely there.  The
answer is unique up to the mirror image in the face plane; both images are
returned.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from minparam_cli.kinematics.parallel.platform_exact import BEZOUT_BOUND, solve_octahedral
from minparam_cli.kinematics.parallel.platform_fk import DEFAULT_RTOL, Certificate


@dataclass(frozen=True)
class TrussModel:
    name: str
    node_names: tuple[str, ...]
    nodes: np.ndarray  # (6, 3) a reference configuration (the file's coordinates)
    legs: np.ndarray  # (12, 2) node indices
    leg_names: tuple[str, ...]
    limits: np.ndarray  # (12, 2), NaN where absent
    length_unit: str = ""

    @property
    def n_legs(self) -> int:
        return len(self.legs)


@dataclass(frozen=True)
class TrussSolution:
    nodes: np.ndarray  # (6, 3) in the frame of the face
    residual: float  # max |l - l*|


@dataclass(frozen=True)
class TrussFKResult:
    frame: tuple[int, int, int]
    target: np.ndarray
    solutions: tuple[TrussSolution, ...]
    rtol: float
    tolerance: float
    certificate: Certificate | None
    note: str = ""


def truss_model(desc) -> TrussModel:
    """Build the model from a ``PlatformDescription`` with structure 'truss'."""
    idx = {n: i for i, n in enumerate(desc.base_names)}
    legs = np.array([[idx[leg.base], idx[leg.platform]] for leg in desc.legs], dtype=int)
    limits = np.array([leg.limits if leg.limits is not None else (np.nan, np.nan) for leg in desc.legs], float)
    return TrussModel(
        name=desc.name,
        node_names=tuple(desc.base_names),
        nodes=np.array(desc.base_coords, dtype=float),
        legs=legs,
        leg_names=tuple(leg.name for leg in desc.legs),
        limits=limits,
        length_unit=desc.length_unit,
    )


def truss_lengths(model: TrussModel, coords) -> np.ndarray:
    """Inverse kinematics: (..., 6, 3) node coordinates -> (..., 12) leg lengths."""
    c = np.asarray(coords, dtype=float)
    return np.linalg.norm(c[..., model.legs[:, 0], :] - c[..., model.legs[:, 1], :], axis=-1)


def _adjacency(model: TrussModel) -> np.ndarray:
    adj = -np.ones((6, 6), dtype=int)
    for k, (a, b) in enumerate(model.legs):
        adj[a, b] = adj[b, a] = k
    return adj


def faces(model: TrussModel) -> list[tuple[int, int, int]]:
    """The eight triangular faces (node triples joined pairwise), in index order."""
    adj = _adjacency(model)
    out = []
    for a in range(6):
        for b in range(a + 1, 6):
            for c in range(b + 1, 6):
                if adj[a, b] >= 0 and adj[b, c] >= 0 and adj[a, c] >= 0:
                    out.append((a, b, c))
    return out


def opposite(model: TrussModel) -> np.ndarray:
    """opp[i]: the one node not joined to node i."""
    adj = _adjacency(model)
    return np.array([[j for j in range(6) if j != i and adj[i, j] < 0][0] for i in range(6)])


def truss_fk(model: TrussModel, target, frame: tuple[int, int, int] | None = None,
             rtol: float = DEFAULT_RTOL) -> TrussFKResult:
    """Every real configuration of the truss for the twelve lengths, in the frame of ``frame``.

    ``frame`` is a face (three mutually joined nodes); the default is the
    first face in node order.  Raises ValueError if ``frame`` is not a face.
    """
    target = np.asarray(target, dtype=float)
    if target.shape != (model.n_legs,):
        raise ValueError(f"expected {model.n_legs} lengths, got {target.size}")
    all_faces = faces(model)
    if frame is None:
        frame = all_faces[0]
    if tuple(sorted(frame)) not in all_faces or len(set(frame)) != 3:
        names = ", ".join(model.node_names[i] for i in frame)
        raise ValueError(f"nodes {names} are not a face of the octahedron (three nodes joined pairwise)")
    adj = _adjacency(model)
    opp = opposite(model)
    face = list(frame)
    face3 = (face[0], face[1], face[2])
    top = [int(opp[i]) for i in face]
    tol = rtol * float(np.max(target))

    lab, lac, lbc = (target[adj[face[0], face[1]]], target[adj[face[0], face[2]]], target[adj[face[1], face[2]]])
    cx = (lab * lab + lac * lac - lbc * lbc) / (2 * lab)
    cy2 = lac * lac - cx * cx
    if cy2 <= (1e-9 * lac) ** 2:  # relative: a flat face cannot fix the frame
        return TrussFKResult(face3, target, (), rtol, tol, None,
                             note="no real assembly: the three frame-face lengths do not make a proper triangle")
    base = np.array([[0.0, 0.0, 0.0], [lab, 0.0, 0.0], [cx, np.sqrt(cy2), 0.0]])
    L = np.zeros((3, 3))
    D = np.zeros((3, 3))
    for i in range(3):
        for k in range(3):
            if i != k:
                L[i, k] = target[adj[face[i], top[k]]]
                D[i, k] = target[adj[top[i], top[k]]]
    sol = solve_octahedral(base, L, D)
    found = []
    for pts in sol.points:
        coords = np.zeros((6, 3))
        coords[face] = base
        coords[top] = pts
        res = float(np.max(np.abs(truss_lengths(model, coords) - target)))
        if res <= tol:
            found.append(TrussSolution(coords, res))
    found.sort(key=lambda s: (-s.nodes[top[0], 2], s.nodes[top[0], 0], s.nodes[top[0], 1]))
    note = ""
    if sol.empty_circle is not None:
        note = f"no real assembly: node {model.node_names[top[sol.empty_circle]]} cannot meet its two face nodes"
    cert = Certificate(sol.n_complex, BEZOUT_BOUND, sol.imag_margin, sol.min_singular, sol.interpolation_error)
    return TrussFKResult(face3, target, tuple(found), rtol, tol, cert, note)
