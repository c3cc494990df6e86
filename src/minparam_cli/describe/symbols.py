"""One symbol, one value: the geometry symbols of a description made distinct before any stage uses them.

Every stage looks geometric values up by symbol (``RobotDescription.geometry``, ``joint_matrices``,
the symbolic stage), so two values under one name silently became one.  Two ways it happened:

* a YAML table naming the same symbol for two different values (``a: {symbol: L, value: 1}`` on one
  joint, ``value: 2`` on another), or naming a symbol the table gives another value automatically
  (``symbol: d2`` while joint 2's d is 0.3): two chosen symbols on different values are refused, naming
  both places; a symbol the loader made up that the file chose for another value (Craig's numbering:
  ``a: {symbol: a2}`` on row 3 of an MDH table, the loader's ``a2`` on row 2) gets a suffix.  The same symbol on equal
  values is one quantity shared (two links of one length) and stays so;
* URDF and MJCF joint names that differ only in what a symbol cannot hold (``a-b`` and ``a_b``, or
  ``elbow`` and ``elbow_joint``): the later joint's automatic symbols get a suffix (``a_b_x_2``).
"""

from __future__ import annotations

from dataclasses import replace

from minparam_cli.describe.records import GeomValue, RobotDescription
from minparam_cli.errors import DescriptionError


def distinct_symbols(desc: RobotDescription) -> RobotDescription:
    """``desc`` with every geometry symbol naming one value (module docstring)."""
    chosen: dict[str, float] = {}  # symbol the file chose -> its value (the first place)
    for jr in desc.joints:
        for table in (jr.dh, jr.origin):
            for gv in (table or {}).values():
                if gv.named:
                    chosen.setdefault(gv.symbol, gv.value)
    seen: dict[str, tuple[GeomValue, str]] = {}  # symbol -> (value, where)
    joints = list(desc.joints)
    for k, jr in enumerate(joints):
        for field in ("dh", "origin"):
            table = getattr(jr, field)
            if not table:
                continue
            renamed = {}
            for key, gv in table.items():
                where = f"joints[{k + 1}].{key}" if field == "dh" else f"joint[{jr.name}]/origin {key}"
                prior = seen.get(gv.symbol)
                clash = prior is not None and not gv.named and not prior[0].named
                # a made-up symbol the file chose for another value (Craig's a2 on row 3, the loader's a2 on row 2)
                clash = clash or (not gv.named and gv.symbol in chosen and chosen[gv.symbol] != gv.value)
                if clash:
                    n = 2
                    while f"{gv.symbol}_{n}" in seen or f"{gv.symbol}_{n}" in chosen:
                        n += 1
                    gv = replace(gv, symbol=f"{gv.symbol}_{n}")
                    renamed[key] = gv
                elif prior is not None and gv.value != prior[0].value:
                    raise DescriptionError(f"symbol '{gv.symbol}' names two different values: {prior[1]} = {prior[0].value:g} "
                                           f"and {where} = {gv.value:g}", desc.source, where)
                seen.setdefault(gv.symbol, (gv, where))
            if renamed:
                new = {**table, **renamed}
                jr = replace(jr, dh=new) if field == "dh" else replace(jr, origin=new)
                joints[k] = jr
    return desc if joints == list(desc.joints) else replace(desc, joints=tuple(joints))

