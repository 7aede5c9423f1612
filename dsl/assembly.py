"""The assembly tree: in which order the joints place the members at t = 0.

Breadth-first from the ground; from each placed member, its joints are visited in
declaration order, hinges, then sliders, welds, ball, cylindrical and universal joints, and
free joints. A joint whose other member is
not yet placed places it (a Placement); a joint whose members are both placed closes a loop
(a free joint cannot: E049). Members with no joint path to the ground start trees of their
own at the origin (warning W001, once per tree), unless a free joint places them.
"""

from __future__ import annotations

from collections import deque

from .errors import Reporter
from .ir import (Ball, Cylindrical, FreeJoint, Hinge, JointKind, Member, MemberKind, Placement,
                 Slider, Universal, Weld)


def assemble(hinges: tuple[Hinge, ...], sliders: tuple[Slider, ...],
             members: list[tuple[Member, str, object]], report: Reporter,
             welds: tuple[Weld, ...] = (), free_joints: tuple[FreeJoint, ...] = (),
             balls: tuple[Ball, ...] = (), cylindricals: tuple[Cylindrical, ...] = (),
             universals: tuple[Universal, ...] = ()
             ) -> tuple[tuple[Placement, ...], tuple[tuple[JointKind, int], ...]]:
    """(placements, loop_joints). `members` lists (member, description, span) of every
    body, beam and particle in declaration order, for the floating-member warning."""
    joints = [(JointKind.HINGE, i, h.a.member, h.b.member) for i, h in enumerate(hinges)]
    joints += [(JointKind.SLIDER, i, s.a.member, s.b.member) for i, s in enumerate(sliders)]
    joints += [(JointKind.WELD, i, w.a.member, w.b.member) for i, w in enumerate(welds)]
    joints += [(JointKind.BALL, i, j.a.member, j.b.member) for i, j in enumerate(balls)]
    joints += [(JointKind.CYLINDRICAL, i, j.a.member, j.b.member)
               for i, j in enumerate(cylindricals)]
    joints += [(JointKind.UNIVERSAL, i, j.a.member, j.b.member)
               for i, j in enumerate(universals)]
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
        group += _fly(free_joints, touching, placed, used, placements, loops)
        if root.kind is not MemberKind.GROUND:
            _warn_floating(root, group, members, report)
    for index, free in enumerate(free_joints):
        if (JointKind.FREE, index) not in used:
            report.error("E049", f"free joint '{free.name}' joins members that other joints "
                         "already join: it would place nothing", free.span,
                         hint="a free joint starts a member of its own moving; remove it, or "
                              "the joints that join its members")
    return tuple(placements), tuple(loops)


def _fly(free_joints: tuple[FreeJoint, ...], touching: dict, placed: set[Member], used: set,
         placements: list, loops: list) -> list[Member]:
    """Place, by the free joints in declaration order, each member that a free joint joins to
    a placed one and no other joint has placed, and what its joints reach from it; again
    until no free joint places anything. The members placed, in order."""
    group: list[Member] = []
    progress = True
    while progress:
        progress = False
        for index, free in enumerate(free_joints):
            a, b = free.a.member, free.b.member
            if (JointKind.FREE, index) in used or (a in placed) == (b in placed):
                continue
            child = b if a in placed else a
            used.add((JointKind.FREE, index))
            placements.append(Placement(JointKind.FREE, index, a if child == b else b, child))
            placed.add(child)
            group += [child] + _grow(child, touching, placed, used, placements, loops)
            progress = True
    return group


def _grow(root: Member, touching: dict, placed: set[Member], used: set, placements: list,
          loops: list) -> list[Member]:
    """Place everything the joints other than free joints reach from `root`; the members
    placed, in order. `touching` gives each member's joints in declaration order, hinges,
    sliders, then welds."""
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
    """One W001 per floating tree, at its first member, naming the others."""
    described = {member: (description, span) for member, description, span in members}
    root_name, root_span = described[root]
    others = [described[member][0] for member in group]
    shown = ", ".join(others[:3]) + (f" and {len(others) - 3} more" if len(others) > 3 else "")
    with_others = f", with {shown}," if others else ""
    name = root_name.split("'")[1] if "'" in root_name else "it"
    point = "a" if root.kind is MemberKind.BEAM else "cm"
    report.warning("W001", f"{root_name} has no joint path to the ground; it floats"
                   f"{with_others} from the origin, at rest", root_span,
                   hint=f"join it to the ground, or to a member that is; or, to let it fly "
                        f"with an initial position and motion of your choosing, declare a free "
                        f"joint, `free {name}_motion joins ground.origin to {name}.{point}`, "
                        f"and give {name}_motion.x, .y, .angle, .vx, .vy, .omega in `initial`")
