"""Effect columns carried through the single streaming pass ("slots").

The final fit needs each joint's triangular factor of [X_j | E_j | τ_j], with
E_j the columns of the effects the diagnosis added.  Those are only known after
the diagnosis, but most effects are fixed functions of the joint's own signals:
the streaming pass factors [X_j | S_j | τ_j] with S_j one column per such
function (the same on every joint: slot k of joint j is that function of joint
j's signals), and the final design's factor follows from it by a linear map of
the columns (``Accumulator.transform``), without reading the file again:

* asymmetric Coulomb, viscous and offset have slots of their own;
* Coulomb is the sum of the two asymmetric Coulomb slots (sign q̇ = [q̇>0] − [q̇<0]);
* gain is the model torque X_j·θ_model, a combination of the base columns.

Every other effect has no slot, and a final design with one of them streams the file again: cogging
and position error (59 orders each), Stribeck friction (7 grid values), load-dependent Coulomb
(|τ_model| is not linear in the columns), and rotor inertia, spring, gravity error and drift.  A
slot column on every joint costs the factor update about 2·Σ_j c_j (it grows with the square of a
joint's columns) on every run, to spare a second pass only on the runs whose final model names that
effect and no effect without a slot.  The slots are the classic friction model (Coulomb, viscous,
offset), the effects nearly every identification adds; both real recordings of the project took a
second pass anyway (docs/methods/streaming.md, "What was tried").
"""

from __future__ import annotations

import numpy as np

from minparam_cli.measured.records import Block
from minparam_cli.identify.passes.design import Design, Term
from minparam_cli.dynamics.effects import EFFECTS, Signals, source_columns

SLOTTED = ("asymmetric_coulomb", "viscous", "offset")
DERIVED = {"coulomb": "asymmetric_coulomb"}  # effect -> the slotted effect it is a combination of
FROM_MODEL = ("gain",)


def slot_sources(effects: tuple[str, ...]) -> tuple[tuple[str, float | None], ...]:
    """(effect, grid value) whose columns get slots, for a diagnosis allowed ``effects``."""
    wanted = {DERIVED.get(e, e) for e in effects}
    out = []
    for eid in SLOTTED:
        if eid in wanted:
            out += [(eid, h) for h in (EFFECTS[eid].grid or (None,))]
    return tuple(out)


def all_joints(effect: str, s: Signals, n: int, hyper: float | None = None) -> np.ndarray:
    """(N, n, m): the effect's columns for every joint at once (the builders index joints as
    ``s.q[:, j]``, so a slice takes them all; a column that does not depend on the joint is repeated)."""
    return _joint_major(np.asarray(EFFECTS[effect].build(s, slice(None), hyper), dtype=float), n)


def sources_columns(sources, s: Signals, n: int) -> list[np.ndarray]:
    """``all_joints`` of every (effect, grid value) of ``sources``, in order; a run of one effect's
    grid values in one sweep where the effect has one (cogging's 59 orders)."""
    out: list[np.ndarray] = []
    i = 0
    while i < len(sources):
        e = sources[i][0]
        k = i
        while k < len(sources) and sources[k][0] == e:
            k += 1
        sweep = EFFECTS[e].sweep
        if sweep is not None:
            out += [_joint_major(np.asarray(c, dtype=float), n) for c in sweep(s, slice(None), [h for _, h in sources[i:k]])]
        else:
            out += [all_joints(e, s, n, h) for _, h in sources[i:k]]
        i = k
    return out


def _joint_major(out: np.ndarray, n: int) -> np.ndarray:
    if out.ndim == 1:
        return np.broadcast_to(out[:, None, None], (len(out), n, 1))
    return out[:, :, None] if out.ndim == 2 else out.transpose(0, 2, 1)


def block_rows(design: Design, sources, b: Block, out: np.ndarray | None = None) -> np.ndarray:
    """Rows of a block for the accumulators, joint-major: (n, design.p + slots + 1, N), joint j's
    rows [design columns | slot columns of joint j | τ_j] transposed in [j] (C-contiguous: the
    layout ``Accumulator.add_columns`` and ``BlockGrams.add_columns`` take without a copy).
    ``out``: a buffer of exactly that shape to fill (identify's streaming pass reuses a few)."""
    n, N = design.chain.dof, len(b)
    shape = (n, source_columns(sources, design.p)[1] + 1, N)
    if out is None:
        out = np.empty(shape)
    elif out.shape != shape or not out.flags.c_contiguous:
        raise ValueError(f"block_rows: expected a C-contiguous buffer of shape {shape}")
    design.rows(b, out)
    out[:, -1] = b.tau.T
    if sources:
        fill_slots(design, sources, b, out)
    return out


def fill_slots(design: Design, sources, b: Block, out: np.ndarray) -> None:
    """The slot columns of ``block_rows``' rows ``out``, in place (the model torque of load
    effects comes from the design columns already in ``out``)."""
    n = design.chain.dof
    s = design.signals(b, tau_model=design.model_torque(out, len(b)))
    c = design.p
    for cols in sources_columns(sources, s, n):
        m = cols.shape[2]
        out[:, c : c + m] = cols.transpose(1, 2, 0)
        c += m


def final_maps(design: Design, sources) -> list[np.ndarray] | None:
    """Per joint, M_j with [X_j | S_j | τ_j] M_j = [columns of ``design`` on joint j | τ_j]; None if a term has no slot."""
    n, p = design.chain.dof, len(design.kept)
    at, k = source_columns(sources)
    width = design.p
    maps = []
    for j in range(n):
        M = np.zeros((p + k + 1, width + 1))
        M[np.arange(p), np.arange(p)] = 1.0
        M[p + k, width] = 1.0
        c = p
        for term in design.terms:
            m = len(EFFECTS[term.effect].column_names)
            for i, jj in enumerate(term.joints):
                if jj == j and not _place(M, term, p, at, c + i * m, design):
                    return None
            c += m * len(term.joints)
        maps.append(M)
    return maps


def _place(M: np.ndarray, term: Term, p: int, at: dict, col: int, design: Design) -> bool:
    """Write the map of ``term``'s columns on one joint into M's columns col.. ; False if it has no slot."""
    e = term.effect
    if e in FROM_MODEL:
        if design.theta_model is None:
            return False
        M[:p, col] = design.theta_model[:p]
        return True
    source = (DERIVED.get(e, e), term.hyper)
    if source not in at:
        return False
    s0 = p + at[source]
    if e == "coulomb":  # sign q̇ = [q̇ > 0] + (−[q̇ < 0])
        M[s0, col] = M[s0 + 1, col] = 1.0
    else:
        m = len(EFFECTS[e].column_names)
        M[s0 + np.arange(m), col + np.arange(m)] = 1.0
    return True
