"""Hinge reaction loads and the records of the deployment summary, as the integrator core
computes them (runtime/c/run/loads.c, recording.c, summary.c).

Sign conventions (docs/deployment.md, section 5). A generated module's hinge rows are
"<h>.x", "<h>.y" = r_a - r_b (a, b the members in the order the hinge joins them;
CONSTRAINT_HINGES names each row's hinge). With
M qdd = f - Phi_q^T lambda, the row's force on member b is +lambda and on member a -lambda, so

    F_h = (lambda_<h>.x, lambda_<h>.y[, lambda_<h>.z])   force on member b from member a, world
                                                       frame (N); a spatial hinge has z

A lock row theta_h - c = 0 (rows "<h>.latch", "<h>.stop", "<h>.stick", "<h>.lock") applies the
generalized force -J_h^T lambda, i.e. the torque

    T_h = -lambda_lock                     on member b, positive in the sense of theta_h (N m)

(and -T_h on member a). A compliant latch's spring torque is reported the same way.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

@dataclass(frozen=True, slots=True)
class HingeLoad:
    """One hinge's loads at the output times (n,): the force on member b from member a in the
    world frame (N) and its magnitude, and the lock torque on member b (N m, NaN while nothing
    holds the hinge angle)."""

    force_x: np.ndarray
    force_y: np.ndarray
    force_z: np.ndarray  # 0 in a planar model
    force: np.ndarray
    torque: np.ndarray


@dataclass(frozen=True, slots=True)
class PeakLoad:
    """Largest hinge force magnitude (N) and lock torque magnitude (N m) over the run, with the
    times (s) they occurred; torque 0 / time NaN when the hinge was never locked."""

    force: float
    t_force: float
    torque: float
    t_torque: float
    unique: bool = True  # False: the hinge's rows were redundant at some state (a singular
    # position, or rows repeating others); its loads are then the minimum-norm ones


@dataclass(frozen=True, slots=True)
class LatchRecord:
    """A latch that engaged: hinge, time (s), hinge rate just before (rad/s), the angular
    impulse the latch applied to member b (N m s; None for a compliant latch), the kinetic
    energy the plastic impact removed (J; None for a compliant latch) and whether it is rigid."""

    hinge: str
    t: float
    rate: float
    impulse: float | None
    energy_loss: float | None
    rigid: bool


@dataclass(frozen=True, slots=True)
class Deployment:
    """What a mechanism engineer asks first. `deployed` is None when the model has no latch;
    `time` (s) is when the last latch engaged (None unless deployed); energies in J."""

    latch_hinges: tuple[str, ...]
    latches: tuple[LatchRecord, ...]
    deployed: bool | None
    time: float | None
    friction_energy: float
    impact_energy: float
