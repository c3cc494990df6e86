"""The tool point of a URDF description: the default one (the fixed link farthest out on the last
moving link) and ``--tool LINK``'s choice among the links rigidly attached to a moving link."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from minparam_cli.describe.records import RobotDescription


def default_tool(attached: list, records: list[dict]):
    """(link, point) of the default tool: of the fixed descendants of the last moving joint's link,
    the one farthest from that link's origin (a tie: the one written last); (None, None) if none."""
    if not records:
        return None, None
    last = len(records) - 1
    best = None
    for link, body, xyz in attached:
        if body != last or link == records[last]["link_name"]:
            continue
        d = float(np.linalg.norm(xyz))
        if best is None or d >= best[0] - 1e-12 * max(1.0, best[0]):
            best = (d, link, xyz)
    return (None, None) if best is None else (best[1], best[2])


def select_tool(desc: RobotDescription, link: str) -> RobotDescription:
    """The description with the tool point at the origin of ``link`` (``--tool LINK``), for a serial
    chain or a branch: if the link sits on a moving body other than the last, the description keeps
    only the joints from the root to that body (renumbered).  InputError (exit 2) naming the links
    allowed when ``link`` is not rigidly attached to a moving link."""
    from minparam_cli.errors import InputError

    allowed = {name: (body, xyz) for name, body, xyz in desc.tool_links}
    if link not in allowed:
        if desc.convention not in ("urdf", "mjcf"):
            raise InputError(f"--tool {link}: {desc.source} is a {desc.convention.upper()} description without links; its tool point is its 'tool' entry")
        names = ", ".join(name for name, _, _ in desc.tool_links)
        raise InputError(f"--tool: no link {link!r} rigidly attached to a moving link in {desc.source}; allowed: {names}")
    body, xyz = allowed[link]
    path = []
    k = body
    while k >= 0:
        path.append(k)
        k = desc.joints[k].parent
    path.reverse()
    joints = desc.joints
    if path != list(range(len(joints))):
        new = {old: i for i, old in enumerate(path)}
        kept = []
        for old in path:
            jr = joints[old]
            mimic = jr.mimic
            if mimic is not None:
                if mimic[0] not in new:
                    raise InputError(f"--tool {link}: joint {jr.name!r} on its path mimics {joints[mimic[0]].name!r}, which is not on the path")
                mimic = (new[mimic[0]], mimic[1], mimic[2])
            kept.append(replace(jr, parent=new.get(jr.parent, -1), mimic=mimic))
        joints = tuple(kept)
    return replace(desc, joints=joints, tool=xyz, tool_link=link)
