"""The quantities outputs may name beyond the state: the loads connectors carry and the
system's momentum, centre of mass and energies (docs/language.md, System outputs).

Everything of the whole system is computed from the mass matrix M, q and qd, so it holds for
any member the layout has (rigid bodies, particles, beams): each coordinate says how it moves
in a rigid motion of the whole system (`rigid_modes`), a translation t_x, t_y and a rotation
r_O about the origin, and then

    mass m = t_x^T M t_x,      first moment m c_x = t_x^T M q,     momentum p_x = t_x^T M qd,
    angular momentum about the origin H_O = r_O(q)^T M qd,  about a point P: H_O - r_P x p,

exact for the consistent mass matrix of every member (a beam's position field is linear in
its coordinates with constant shape functions). Loads come from the multipliers of the model's
rows (`lam`, NC) and from the run values the integrator core supplies (`w`, NW: each hinge's
lock torque, the work of each dissipator, of friction, of compliant latches and impacts, and
the compliant latches' potential energy; depsim.runtime.interface, RUN_VALUES)."""

from __future__ import annotations

from dataclasses import dataclass

import sympy

from depsim.dsl import ir

from .kinematics import Kinematics, core_sliders
from .spatial import times

# The columns of the generated system_state(q, qd, p) (depsim.runtime.interface).
SYSTEM_STATE = ("mass", "com_x", "com_y", "momentum_x", "momentum_y", "angular_momentum")

# The run values after the hinges' lock torques and the model's dissipators' work, in order.
RUN_TOTALS = ("work.friction", "work.latch", "work.impacts", "energy.latch")


def run_value_names(model: ir.Model, dissipators: tuple[str, ...]) -> tuple[str, ...]:
    """The names of the run values w an output may use, in their order (RUN_VALUES): each
    hinge's lock torque, each slider of core_sliders' lock force along its axis, the
    dissipators' work, RUN_TOTALS."""
    return (tuple(f"{h.name}.torque" for h in model.hinges)
            + tuple(f"{model.sliders[i].name}.force" for i in core_sliders(model))
            + tuple(f"work.{name}" for name in dissipators) + RUN_TOTALS)


def rigid_modes(kin: Kinematics) -> tuple[list, list, list]:
    """(t_x, t_y, r_O): how each coordinate moves per unit of a rigid translation of the whole
    system along x, along y, and per radian of a rigid rotation about the origin (NQ each,
    expressions of q). Bodies: (x, y, phi); particles: (x, y); beams: node positions (x, y)
    and slope vectors (dx, dy), which rotate but do not translate."""
    one, zero = sympy.Integer(1), sympy.Integer(0)
    tx, ty, rot = [], [], []
    for index in range(len(kin.model.bodies)):
        x, y, _ = kin.body_symbols(index)
        tx += [one, zero, zero]
        ty += [zero, one, zero]
        rot += [-y, x, one]
    for index in range(len(kin.model.particles)):
        x, y = kin.particle_symbols(index)
        tx += [one, zero]
        ty += [zero, one]
        rot += [-y, x]
    for symbols in kin.symbols.beam_q:
        for node in range(len(symbols) // 4):
            x, y, dx, dy = symbols[4 * node:4 * node + 4]
            tx += [one, zero, zero, zero]
            ty += [zero, one, zero, zero]
            rot += [-y, x, -dy, dx]
    assert len(tx) == len(kin.symbols.q), "a member kind without its rigid modes"
    return tx, ty, rot


def _weighted(mass: sympy.SparseMatrix, left: list, right) -> sympy.Expr:
    """left^T M right, summing the non-zeros of M only."""
    return sympy.Add(*(value * left[i] * right[j]
                       for (i, j), value in sorted(mass.todok().items())
                       if left[i] != 0 and right[j] != 0))


@dataclass(frozen=True)
class RowIndex:
    """Where each connector's rows are among the model's rows: (joint, component) -> row."""

    rows: dict[tuple[str, str], int]


class OutputScope:
    """The scope of output expressions: the state through `kin`, the loads through the
    multipliers `lam` and the run values `w`, the system's quantities through M."""

    def __init__(self, kin: Kinematics, mass: sympy.SparseMatrix, lam: tuple[sympy.Symbol, ...],
                 w: tuple[sympy.Symbol, ...], rows: RowIndex, energies: tuple[sympy.Expr, ...],
                 dissipators: tuple[str, ...], springs) -> None:
        self.kin = kin
        self.p, self.t = kin.p, kin.t
        self.mass = mass
        self.lam, self.w, self.rows = lam, w, rows
        self.energies, self.dissipators, self.springs = energies, dissipators, springs
        self._modes = None

    # the state: as Kinematics has it
    def body_coord(self, body, coord):
        return self.kin.body_coord(body, coord)

    def point_coord(self, member, point, axis):
        return self.kin.point_coord(member, point, axis)

    def hinge_angle(self, hinge, rate):
        return self.kin.hinge_angle(hinge, rate)

    def slider_position(self, slider, rate):
        return self.kin.slider_position(slider, rate)

    def beam_quantity(self, beam, kind):
        return self.kin.beam_quantity(beam, kind)

    # loads
    def joint_load(self, kind: str, index: int, quantity: str) -> sympy.Expr:
        if kind == "spring":
            law = self.springs[index]
            return {"force": law.force, "length": law.length, "rate": law.rate}[quantity]
        if kind == "slider" and quantity != "force":  # its rows' reaction, spatial
            return self._slider_reaction(index, quantity)
        if kind == "slider":  # its lock force (run value), 0 when nothing can lock it
            sliding = core_sliders(self.kin.model)
            if index not in sliding:
                return sympy.Integer(0)
            return self.w[len(self.kin.model.hinges) + sliding.index(index)]
        model = self.kin.model
        joint = {"hinge": model.hinges, "weld": model.welds, "ball": model.balls,
                 "cylindrical": model.cylindricals, "universal": model.universals}[kind][index]
        if kind in ("cylindrical", "universal"):
            value = self.kin.joint_value(kind, index, quantity)
            if value is not None:
                return value
        if quantity.startswith("moment"):
            moment = self.kin.reaction_moment(kind, index, self._row_multipliers(joint.name))
            if quantity == "moment":
                return sympy.sqrt(sympy.Add(*(value**2 for value in moment)))
            return moment["xyz".index(quantity[-1])]
        if quantity == "torque":
            if kind == "hinge":
                return self.w[index]
            row = self.rows.rows.get((joint.name, "angle"))
            return sympy.Integer(0) if row is None else -self.lam[row]
        axes = "xyz" if self.kin.model.spatial else "xy"
        if kind == "cylindrical":  # its normal rows (R_A e) . d, (R_A f) . d: on B -lambda e ...
            parts, lam = self.kin.cylindrical_parts(index), self._row_multipliers(joint.name)
            force = {f"force_{axis}": -(lam["normal_1"] * parts["e"][k]
                                        + lam["normal_2"] * parts["f"][k])
                     for k, axis in enumerate(axes)}
        else:
            force = {f"force_{axis}": self.lam[self.rows.rows[(joint.name, axis)]]
                     for axis in axes}
        force["force"] = sympy.sqrt(sympy.Add(*(value**2 for value in force.values())))
        return force[quantity]

    def _slider_reaction(self, index: int, quantity: str) -> sympy.Expr:
        """A spatial slider's reaction on B from A through its rows (world frame): the force
        of its normal rows (R_A e) . d, (R_A f) . d, -(lambda_1 R_A e + lambda_2 R_A f), normal
        to the axis; the moment of its turn rows about B's point, as a weld's (none on a
        particle)."""
        slider = self.kin.model.sliders[index]
        lam = self._row_multipliers(slider.name)
        if quantity.startswith("moment"):
            moment = self.kin.reaction_moment("slider", index, lam)
            if quantity == "moment":
                return sympy.sqrt(sympy.Add(*(value**2 for value in moment)))
            return moment["xyz".index(quantity[-1])]
        _, e, f = self.kin.slider_frame(index)
        rotation = self.kin.rotation(slider.a.member)
        e, f = times(rotation, e), times(rotation, f)
        return -(lam["normal_1"] * e["xyz".index(quantity[-1])]
                 + lam["normal_2"] * f["xyz".index(quantity[-1])])

    def _row_multipliers(self, joint: str) -> dict[str, sympy.Expr]:
        """A joint's multipliers by their rows' components (x, axis_1, rx, ...)."""
        return {component: self.lam[row] for (name, component), row in self.rows.rows.items()
                if name == joint}

    # the system
    def _rigid(self):
        """(translations, rotations): rigid_modes of a planar model, or of a spatial one."""
        if self._modes is None:
            if self.kin.model.spatial:
                self._modes = self.kin.rigid_modes()
            else:
                tx, ty, rot = rigid_modes(self.kin)
                self._modes = ([tx, ty], [rot])
        return self._modes

    def system_quantity(self, quantity: str, point: ir.Attachment | None) -> sympy.Expr:
        translations, rotations = self._rigid()
        q, qd, M = self.kin.symbols.q, self.kin.symbols.qd, self.mass
        axes = "xyz"[:len(translations)]
        mass = _weighted(M, translations[0], translations[0])
        nd = len(self.dissipators)
        nh = len(self.w) - nd - len(RUN_TOTALS)  # the hinge entries' lock loads come first
        totals = dict(zip(RUN_TOTALS, self.w[nh + nd:]))
        if quantity == "mass":
            return mass
        centre = {axis: _weighted(M, mode, q) / mass for axis, mode in zip(axes, translations)}
        momentum = {axis: _weighted(M, mode, qd) for axis, mode in zip(axes, translations)}
        if quantity.startswith("com_v"):
            return momentum[quantity[-1]] / mass
        if quantity.startswith("com_"):
            return centre[quantity[-1]]
        if quantity.startswith("momentum_"):
            return momentum[quantity[-1]]
        if quantity == "angular_momentum":  # planar: about z, through a point or the centre
            about = (self.kin.point_position(point.member, point.point) if point is not None
                     else (centre["x"], centre["y"]))
            return (_weighted(M, rotations[0], qd) - (about[0] * momentum["y"]
                                                      - about[1] * momentum["x"]))
        if quantity.startswith("angular_momentum_"):  # spatial: about the centre of mass
            k = "xyz".index(quantity[-1])
            i, j = (k + 1) % 3, (k + 2) % 3
            moment = centre["xyz"[i]] * momentum["xyz"[j]] - centre["xyz"[j]] * momentum["xyz"[i]]
            return _weighted(M, rotations[k], qd) - moment
        kinetic, potential = self.energies[0], sympy.Add(*self.energies[1:]) \
            + totals["energy.latch"]
        if quantity in ("kinetic_energy", "potential_energy", "energy"):
            return {"kinetic_energy": kinetic, "potential_energy": potential,
                    "energy": kinetic + potential}[quantity]
        damping = sympy.Add(*(self.w[nh + d] for d, name in enumerate(self.dissipators)
                              if name.startswith("damping."))) + totals["work.latch"]
        parts = {"dissipated_friction": totals["work.friction"],
                 "dissipated_damping": damping, "dissipated_impacts": totals["work.impacts"]}
        if quantity == "dissipated":
            return sympy.Add(*parts.values())
        return parts[quantity]
