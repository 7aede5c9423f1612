"""The assembly tree: in which order the joints place the members at t = 0.

Breadth-first from the ground; from each placed member, its joints are visited in
declaration order, hinges before sliders. A joint whose other member is not yet placed
places it (a Placement); a joint whose members are both placed closes a loop. Members
with no joint path to the ground start trees of their own at the origin (warning W001).
"""

from __future__ import annotations

from collections import deque

from .errors import Reporter
from .ir import Hinge, JointKind, Member, MemberKind, Placement, Slider


def assemble(hinges: tuple[Hinge, ...], sliders: tuple[Slider, ...],
             members: list[tuple[Member, str, object]], report: Reporter
             ) -> tuple[tuple[Placement, ...], tuple[tuple[JointKind, int], ...]]:
    """(placements, loop_joints). `members` lists (member, description, span) of every
    body and beam in declaration order, for the floating-member warning."""
    joints = [(JointKind.HINGE, i, h.a.member, h.b.member) for i, h in enumerate(hinges)]
    joints += [(JointKind.SLIDER, i, s.a.member, s.b.member) for i, s in enumerate(sliders)]
    touching: dict[Member, list] = {}  # member -> its joints, in the order of `joints`
    for joint in joints:
        for end in dict.fromkeys(joint[2:]):
            touching.setdefault(end, []).append(joint)
    placed: set[Member] = set()
    used: set[tuple[JointKind, int]] = set()
    placements: list[Placement] = []
    loops: list[tuple[JointKind, int]] = []
    roots = [Member(MemberKind.GROUND, 0)] + [m for m, _, _ in members]
    for root in roots:
        if root in placed:
            continue
        placed.add(root)
        group = _grow(root, touching, placed, used, placements, loops)
        if root.kind is not MemberKind.GROUND:
            _warn_floating(root, group, members, report)
    return tuple(placements), tuple(loops)


def _grow(root: Member, touching: dict, placed: set[Member], used: set, placements: list,
          loops: list) -> list[Member]:
    """Place everything reachable from `root`; the members placed, in order. `touching`
    gives each member's joints in declaration order, hinges before sliders."""
    group = []
    queue = deque([root])
    while queue:
        parent = queue.popleft()
        for kind, index, a, b in touching.get(parent, ()):
            if (kind, index) in used:
                continue
            used.add((kind, index))
            child = b if parent == a else a
            if child in placed:
                loops.append((kind, index))
                continue
            placements.append(Placement(kind, index, parent, child))
            placed.add(child)
            group.append(child)
            queue.append(child)
    return group


def _warn_floating(root: Member, group: list[Member], members, report: Reporter) -> None:
    described = {member: (description, span) for member, description, span in members}
    root_name, root_span = described[root]
    report.warning("W001", f"{root_name} has no joint path to the ground; it floats, and "
                   "its initial pose is the origin", root_span,
                   hint="join it to the ground or to a member that is")
    for member in group:
        name, span = described[member]
        report.warning("W001", f"{name} has no joint path to the ground; it floats with "
                       f"{root_name}", span)
