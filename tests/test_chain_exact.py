"""chain.exact is computed on first use; it equals what build_chain used to compute eagerly."""

from __future__ import annotations

from dataclasses import replace
from fractions import Fraction

from minparam_cli.base.qr import derive_qr
from minparam_cli.chain import _DERIVED, build_chain
from minparam_cli.describe import load_description
from minparam_cli.joint_matrices import NotExact, Numbers, joint_matrices


def computed(chain) -> dict:
    """The values derived from this chain so far (kept beside it by chain.derived)."""
    return _DERIVED.get(chain, {})


def eager_exact(desc):
    """The exact matrices as build_chain computed them before they became lazy."""
    try:
        emats = joint_matrices(desc, Numbers(True, None))
    except NotExact:
        return None
    return tuple((tuple(tuple(r) for r in p), tuple(a), tuple(tuple(r) for r in q)) for p, a, q in emats)


def test_lazy_exact_equals_the_eager_one(robot_path):
    desc = load_description(robot_path)
    chain = build_chain(desc)
    assert "exact" not in computed(chain)  # not computed by build_chain
    expected = eager_exact(desc)
    assert chain.exact == expected
    assert chain.exact is chain.exact  # computed once
    if expected is not None:
        flat = [x for p, a, q in chain.exact for x in (*sum(p, ()), *a, *sum(q, ()))]
        assert all(type(x) is Fraction for x in flat)


def test_derive_qr_does_not_compute_the_exact_matrices():
    chain = build_chain(load_description("robots/puma560.yaml"))
    derive_qr(chain, samples=20)
    assert "exact" not in computed(chain)
    assert chain.exact is not None  # the PUMA's geometry is exact when asked


def test_copies_keep_the_exact_geometry_and_other_values_drop_it():
    desc = load_description("robots/puma560_mdh.yaml")
    chain = build_chain(desc)
    expected = eager_exact(desc)
    assert chain.with_extras(tuple(("viscous",) for _ in range(chain.n))).exact == expected
    assert replace(chain, name="copy").exact == expected
    assert build_chain(desc, values={"d3": 0.15}).exact is None
    assert build_chain(desc, values={}).exact == expected  # no override: still exact
    assert build_chain(load_description("robots/iiwa14.urdf")).exact is None
