"""What the runtime needs from a generated module, checked once per run.

`System` binds a generated module (see docs/generated-module.md) to one parameter vector and
holds the constant mass matrix, factorised once per run (inverted if diagonal, Cholesky
otherwise). `resolve_settings` fills t_end, dt_out and tol from the module's defaults.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from .errors import SolverError

REQUIRED = ("MODEL_NAME", "NQ", "NC", "NP", "COORDINATES", "PARAMETERS", "PARAMETER_DEFAULTS",
            "CONSTRAINTS", "CONSTRAINT_JOINTS", "PHI_Q_ROWS", "PHI_Q_COLS", "HINGES",
            "SLIDERS", "OUTPUTS", "OUTPUT_UNITS", "ENERGIES", "DISSIPATORS", "T_END", "TOL",
            "DT_OUT", "mass_matrix", "initial_state", "phi", "phi_q", "phi_t", "gamma",
            "force", "hinge_angles", "hinge_rates", "hinge_jacobian", "outputs", "energy",
            "dissipation")

# Below this tolerance double precision cannot resolve a step error or a constraint residual.
TOL_FLOOR = 100 * np.finfo(float).eps


@dataclass(frozen=True, slots=True)
class Settings:
    """One run's settings, SI: end time (s), output interval (s), tolerance (-), parameters."""

    t_end: float
    dt_out: float
    tol: float
    params: np.ndarray


def check_module(module) -> None:
    """Raise TypeError naming what a generated module lacks (a programming error upstream)."""
    missing = [name for name in REQUIRED if not hasattr(module, name)]
    if missing:
        raise TypeError(f"{module!r} is not a depsim generated module: missing "
                        + ", ".join(missing) + " (see docs/generated-module.md)")


def resolve_settings(module, params=None, t_end=None, dt_out=None, tol=None) -> Settings:
    """Fill unset values from the module (PARAMETER_DEFAULTS, T_END, DT_OUT, TOL) and check them.

    Raises ValueError for a bad value (wrong parameter count, non-positive times) and
    SolverError for a tolerance tighter than double-precision round-off.
    """
    p = np.array(module.PARAMETER_DEFAULTS if params is None else params, dtype=float)
    if p.shape != (module.NP,):
        raise ValueError(f"params must have shape ({module.NP},) for model "
                         f"'{module.MODEL_NAME}' ({', '.join(module.PARAMETERS)}); "
                         f"got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        bad = [n for n, v in zip(module.PARAMETERS, p) if not np.isfinite(v)]
        raise ValueError(f"parameters are not finite: {', '.join(bad)}")
    t_end = float(module.T_END if t_end is None else t_end)
    dt_out = float(module.DT_OUT if dt_out is None else dt_out)
    tol = float(module.TOL if tol is None else tol)
    if not (np.isfinite(t_end) and t_end > 0):
        raise ValueError(f"t_end must be a positive number of seconds, got {t_end}")
    if not (np.isfinite(dt_out) and 0 < dt_out):
        raise ValueError(f"dt_out must be a positive number of seconds, got {dt_out}")
    if not (np.isfinite(tol) and 0 < tol < 1):
        raise ValueError(f"tol must lie between 0 and 1, got {tol}")
    if tol < TOL_FLOOR:
        raise SolverError(f"tol = {tol:.3g} is tighter than double-precision round-off",
                          stage="settings", hint=f"use tol >= {TOL_FLOOR:.1e}")
    return Settings(t_end, dt_out, tol, p)


class MassMatrix:
    """The constant mass matrix M (NQ, NQ), factorised once: `solve(b)` returns M^-1 b."""

    def __init__(self, matrix: np.ndarray, coordinates):
        matrix = np.asarray(matrix, dtype=float)
        self.matrix = matrix
        self.diagonal = bool(np.count_nonzero(matrix - np.diag(np.diag(matrix))) == 0)
        if self.diagonal:
            d = np.diag(matrix)
            if np.any(d <= 0):
                k = int(np.argmin(d))
                raise SolverError(f"mass matrix entry of coordinate '{coordinates[k]}' is "
                                  f"{d[k]:.3g}; every body needs positive mass and inertia",
                                  stage="setup", hint="check the body's mass and inertia")
            self.inverse_diagonal = 1.0 / d
            self._cholesky = None
        else:
            try:
                self._cholesky = scipy.linalg.cho_factor(matrix)
            except np.linalg.LinAlgError:
                raise SolverError("mass matrix is not positive definite", stage="setup",
                                  hint="check masses, inertias and beam properties") from None
            self.inverse_diagonal = None

    def solve(self, b: np.ndarray) -> np.ndarray:
        """M^-1 b for b of shape (NQ,) or (NQ, k)."""
        if self.diagonal:
            return (self.inverse_diagonal * b.T).T
        return scipy.linalg.cho_solve(self._cholesky, b)


class System:
    """A generated module bound to one parameter vector `p` (NP,)."""

    def __init__(self, module, p: np.ndarray):
        check_module(module)
        self.module = module
        self.p = p
        self.nq = int(module.NQ)
        self.nd = len(module.DISSIPATORS)
        self.name = str(module.MODEL_NAME)
        self.mass = MassMatrix(module.mass_matrix(p), module.COORDINATES)

    def force(self, q, qd, t):
        """Applied generalized force f (NQ,), SI."""
        return self.module.force(q, qd, t, self.p)

    def dissipation(self, q, qd, t):
        """Power removed by each dissipator (ND,), W."""
        if self.nd == 0:
            return np.zeros(0)
        return np.asarray(self.module.dissipation(q, qd, t, self.p), dtype=float)

    def joint_kind(self, joint: str) -> str:
        """'hinge', 'slider' or 'joint' for a name in CONSTRAINT_JOINTS."""
        if joint in self.module.HINGES:
            return "hinge"
        if joint in self.module.SLIDERS:
            return "slider"
        return "joint"
