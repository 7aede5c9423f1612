"""Calibration: the weighted nonlinear least-squares fit of a model's parameters to what a
ground test measured, time histories of outputs and event times (docs/calibration.md).

The Jacobian comes from the forward sensitivities the core follows along each run
(`Result.sensitivities`, docs/method.md 12), never from finite differences; the least squares
are scipy's trust-region reflective method within the parameters' bounds. Plain data in
(`Measurements`, `FreeParameter`), a `FitResult` out: reading files and units is the
facade's (depsim.measurements).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from .errors import SolverError
from .fit_result import FitResult, uncertainty
from .runner import simulate

MAX_ROWS = 200_000  # the most output rows a run of the fit records
REJECTED = 1e10  # each weighted residual of a trial point that misses a measured event
MAX_ROUNDS = 5  # fits with the noise re-estimated, when it is estimated for several kinds
SIGMA_SETTLED = 0.05  # relative change of every estimated noise that ends the rounds


class FitError(RuntimeError):
    """The fit cannot go on: a run failed, or reached parameters the model refuses, at the
    parameter values the message names (CLI exit code 3)."""


class RefusedPointError(FitError):
    """A point the model refuses (a range check) or whose run fails: a trial point of the
    search is rejected (its step shrinks), the start point is an error."""


class MissingEventError(FitError):
    """A measured event the run does not produce; `index` is its place in
    `Measurements.events`."""

    def __init__(self, message: str, index: int):
        super().__init__(message)
        self.index = index


class NoiseError(ValueError):
    """The noise of a kind of measured values is to be estimated, but there are no more
    values than free parameters."""


@dataclass(frozen=True)
class Measurements:
    """What a ground test measured, in SI. Time histories: `times` (n,) s, non-decreasing,
    and `values` (n, m), a column per model output named in `columns` (`units`: the output's
    SI unit), `sigmas` (m,) each column's noise (NaN: estimated from the residuals). Event
    times: `events` (e,) record names ("h1.latch"), `event_times` (e,) s, `event_sigmas`
    (e,) s (NaN: estimated). `sources`: the files, for the report."""

    columns: tuple[str, ...] = ()
    units: tuple[str, ...] = ()
    times: np.ndarray = field(default_factory=lambda: np.empty(0))
    values: np.ndarray = field(default_factory=lambda: np.empty((0, 0)))
    sigmas: np.ndarray = field(default_factory=lambda: np.empty(0))
    events: tuple[str, ...] = ()
    event_times: np.ndarray = field(default_factory=lambda: np.empty(0))
    event_sigmas: np.ndarray = field(default_factory=lambda: np.empty(0))
    sources: tuple[str, ...] = ()

    @property
    def size(self) -> int:
        """How many measured values: every column's samples and every event time."""
        return self.values.size + len(self.events)


@dataclass(frozen=True, slots=True)
class FreeParameter:
    """A parameter the fit adjusts: its name, index in the parameter vector, start value and
    bounds (SI; -inf / inf for none) and its unit (for the report)."""

    name: str
    index: int
    start: float
    low: float = -np.inf
    high: float = np.inf
    unit: str = ""


@dataclass(frozen=True)
class Settings:
    """The runs' settings: end time and output interval (s), tolerance."""

    t_end: float
    dt_out: float
    tol: float | None


def output_interval(times: np.ndarray, t_end: float, dt_model: float) -> float:
    """The output interval of the fit's runs (s): half the smallest spacing of the measured
    times, no coarser than the model's own dt_out, no finer than t_end / MAX_ROWS."""
    spacing = np.diff(np.unique(times))
    finest = spacing.min() / 2 if len(spacing) else dt_model
    return max(min(finest, dt_model), t_end / MAX_ROWS)


@dataclass(frozen=True)
class _Evaluation:
    """The model at one parameter point: outputs at the measured times (n, m) and event
    times (e,), the residuals (model - measured; columns one after the other, then the
    events) and their Jacobian (N, k)."""

    outputs: np.ndarray
    event_times: np.ndarray
    residuals: np.ndarray
    jacobian: np.ndarray


class _Runs:
    """Runs the model with its sensitivities at parameter points, the last one kept:
    least_squares asks for the residuals and the Jacobian of a point separately."""

    def __init__(self, module, base: np.ndarray, free: Sequence[FreeParameter],
                 data: Measurements, settings: Settings, check: Callable | None):
        self.module, self.base, self.free = module, base, tuple(free)
        self.data, self.settings, self.check = data, settings, check
        self.columns = [list(module.OUTPUTS).index(name) for name in data.columns]
        self.count = 0
        self.rejected: list[str] = []  # why trial points were rejected
        self._last: tuple[bytes, _Evaluation | None] | None = None

    def at(self, x: np.ndarray) -> _Evaluation | None:
        """The model at x; None for a trial point whose run misses a measured event, that
        the model refuses (a range check) or whose run fails (the first point's raises)."""
        key = np.asarray(x, dtype=float).tobytes()
        if self._last is None or self._last[0] != key:
            try:
                found = self._evaluate(np.asarray(x, dtype=float))
            except (MissingEventError, RefusedPointError) as exc:
                if self._last is None:
                    raise
                self.rejected.append(str(exc))
                found = None
            self._last = key, found
        return self._last[1]

    def residuals(self, x: np.ndarray, weight: np.ndarray) -> np.ndarray:
        """The weighted residuals at x; at a trial point that misses a measured event,
        REJECTED each: the least squares reject the step and shrink their trust region."""
        found = self.at(x)
        return found.residuals * weight if found is not None else np.full(len(weight), REJECTED)

    def jacobian(self, x: np.ndarray, weight: np.ndarray) -> np.ndarray:
        """The weighted Jacobian at x (asked only at accepted points, which have a run)."""
        return self.at(x).jacobian * weight[:, None]

    def _evaluate(self, x: np.ndarray) -> _Evaluation:
        p = self.base.copy()
        p[[f.index for f in self.free]] = x
        where = describe_point(self.free, x)
        problems = self.check(p) if self.check is not None else []
        if problems:
            raise RefusedPointError(f"the fit reached {where}, which the model refuses: "
                           f"{'; '.join(problems)}; bound the parameters (--free "
                           "NAME=LOW:HIGH)")
        self.count += 1
        try:
            result = simulate(self.module, p, t_end=self.settings.t_end,
                              dt_out=self.settings.dt_out, tol=self.settings.tol,
                              sensitivities=[f.name for f in self.free])
        except (SolverError, ValueError) as exc:
            raise RefusedPointError(f"the run at {where} failed: {exc}") from exc
        outputs, slopes = _at_times(result, self.data.times, self.columns)
        times, rates = _event_times(result, self.data.events, where)
        residuals = np.concatenate(((outputs - self.data.values).T.ravel(),
                                    times - self.data.event_times))
        jacobian = np.concatenate((slopes.transpose(1, 0, 2).reshape(-1, len(self.free)),
                                   rates))
        if not np.isfinite(jacobian).all():
            raise FitError(f"at {where} the run has no sensitivity of a measured output or "
                           "event (a dissipated work's, an event's time not followed)")
        return _Evaluation(outputs, times, residuals, jacobian)


def describe_point(free: Sequence[FreeParameter], x: np.ndarray) -> str:
    """"h1.friction = 0.7 N*m, ...": the free parameters' values."""
    return ", ".join(f"{f.name} = {v:.8g}{' ' + f.unit if f.unit else ''}"
                     for f, v in zip(free, x))


def _at_times(result, times: np.ndarray, columns: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """Outputs (n, m) and their sensitivities (n, m, k) at the measured times: a cubic spline
    through the run's rows, one between each two events. The outputs have a kink at an
    impact and their sensitivities a jump, so no spline spans one; within a piece the
    spline's error is (5/384) dt_out^4 max|y''''|, for INTELSAT V at dt_out = 5 ms below
    1e-7 rad (6e-8 measured against a run at 2.5 ms), four orders of magnitude below the
    noise of an angle measured to 1e-3 rad."""
    from scipy.interpolate import CubicSpline

    rows = result.times
    values = result.outputs[:, columns]
    slopes = result.sensitivities.outputs[:, :, columns].transpose(0, 2, 1)  # (rows, m, k)
    breaks = np.array(sorted({e.t for e in result.events if e.t > 0}))
    row_piece = np.searchsorted(breaks, rows, side="right")
    data_piece = np.searchsorted(breaks, times, side="right")
    outputs = np.empty((len(times), len(columns)))
    derivatives = np.empty((len(times), len(columns), slopes.shape[2]))
    for piece in np.unique(data_piece):
        wanted, known = data_piece == piece, row_piece == piece
        if known.sum() < 2:  # events closer than two rows: the spline through all rows
            known = np.ones(len(rows), dtype=bool)
        outputs[wanted] = CubicSpline(rows[known], values[known])(times[wanted])
        derivatives[wanted] = CubicSpline(rows[known], slopes[known])(times[wanted])
    return outputs, derivatives


def _event_times(result, names: Sequence[str], where: str) -> tuple[np.ndarray, np.ndarray]:
    """The run's times (e,) of the measured events and their sensitivities (e, k): the j-th
    measured event of a name is the run's j-th record of that name."""
    recorded = [e.name for e in result.events]
    indices = []
    for i, name in enumerate(names):
        occurrence = list(names[:i]).count(name)
        matches = [k for k, n in enumerate(recorded) if n == name]
        if occurrence >= len(matches):
            happened = ", ".join(f"{n} at {result.events[k].t:.6g} s"
                                 for k, n in enumerate(recorded)) or "none"
            nth = f" a {occurrence + 1}. time" if occurrence else ""
            raise MissingEventError(f"event {name} does not happen{nth} in the run at {where} "
                                    f"(to t = {result.t_end:g} s; its events: {happened})", i)
        indices.append(matches[occurrence])
    times = np.array([result.events[k].t for k in indices], dtype=float)
    followed = len(result.sensitivities.parameters)
    rates = result.sensitivities.event_times[indices] if indices else np.empty((0, followed))
    return times, rates


def _groups(data: Measurements) -> list[tuple[str, np.ndarray]]:
    """The kinds of measured values whose noise is estimated (no sigma given), each with its
    residuals' indices: columns by their unit, the event times together."""
    n, found = len(data.times), {}
    for j, (unit, sigma) in enumerate(zip(data.units, data.sigmas)):
        if np.isnan(sigma):
            found.setdefault(f"columns in {unit or '1'}", []).extend(range(j * n, (j + 1) * n))
    for i, sigma in enumerate(data.event_sigmas):
        if np.isnan(sigma):
            found.setdefault("event times", []).append(data.values.size + i)
    return [(kind, np.array(indices)) for kind, indices in found.items()]


def _known_sigmas(data: Measurements) -> np.ndarray:
    """Each residual's noise as given (NaN where it is estimated)."""
    return np.concatenate((np.repeat(data.sigmas, len(data.times)), data.event_sigmas))


def _estimate(sigma: np.ndarray, groups, residuals: np.ndarray, free: int) -> np.ndarray:
    """`sigma` with each estimated group's noise from its residuals: the root of their sum of
    squares over the group's share of the degrees of freedom."""
    sigma = sigma.copy()
    for _, indices in groups:
        dof = len(indices) * (1 - free / len(residuals))
        rms = np.sqrt(np.sum(residuals[indices] ** 2) / dof)
        sigma[indices] = rms if rms > 0 else 1.0
    return sigma


def fit(module, base: np.ndarray, free: Sequence[FreeParameter], data: Measurements, *,
        settings: Settings, check: Callable | None = None, model: str = "") -> FitResult:
    """Fit the free parameters of `module` (a model with tangent functions) to `data`,
    starting at their `start`, the others at `base` (NP,) SI. Weighted least squares: each
    residual (model - measured) over its noise; noise not given is estimated per kind from
    the residuals at the optimum (several kinds: fitted again with the estimates until they
    settle). `check(p)`: the model's range checks' messages for a parameter vector. A trial
    point whose run misses a measured event, that the model refuses (a range check) or whose
    run fails is rejected (the trust region shrinks; listed in FitResult.rejected). Raises
    MissingEventError when the run at the start misses one, FitError when the start point
    is refused or its run fails, NoiseError when the noise cannot be estimated (no more
    values than free parameters)."""
    from scipy.optimize import least_squares

    started = time.perf_counter()
    groups = _groups(data)
    if groups and data.size <= len(free):
        raise NoiseError(f"{data.size} measured values for {len(free)} free parameters: "
                         "their noise cannot be estimated; give each kind's sigma")
    runs = _Runs(module, base, free, data, settings, check)
    x0 = np.array([f.start for f in free], dtype=float)
    bounds = (np.array([f.low for f in free]), np.array([f.high for f in free]))
    scale = _scales(free)
    initial = runs.at(x0)
    # the first weights of estimated kinds: the residuals at the start
    sigma = _estimate(_known_sigmas(data), groups, initial.residuals, 0)
    x, iterations, evaluations = x0, 0, 0
    for _ in range(MAX_ROUNDS):
        weight = 1 / sigma
        solution = least_squares(runs.residuals, x, jac=runs.jacobian, args=(weight,),
                                 bounds=bounds, method="trf", x_scale=scale)
        x = solution.x
        iterations, evaluations = iterations + solution.njev, evaluations + solution.nfev
        estimated = _estimate(sigma, groups, runs.at(x).residuals, len(free))
        settled = np.all(np.abs(estimated - sigma) <= SIGMA_SETTLED * sigma)
        sigma = estimated
        if len(groups) + np.isfinite(_known_sigmas(data)).any() <= 1 or settled:
            break
    final = runs.at(x)
    weighted = final.residuals / sigma
    errors = uncertainty(final.jacobian / sigma[:, None], scale)
    n = len(data.times)
    return FitResult(
        model=model, parameters=tuple(f.name for f in free),
        units=tuple(f.unit for f in free), start=x0, estimates=x,
        bounds=np.column_stack(bounds), standard_errors=errors.standard_errors,
        correlation=errors.correlation, identifiable=errors.identifiable,
        notes=errors.notes(tuple(f.name for f in free)),
        singular_values=errors.singular_values,
        columns=data.columns, column_units=data.units, times=data.times,
        measured=data.values, fitted=final.outputs, initial=initial.outputs,
        sigmas=sigma[:data.values.size:n] if n else np.empty(0),
        sigmas_estimated=tuple(bool(np.isnan(s)) for s in data.sigmas),
        events=data.events, event_measured=data.event_times,
        event_fitted=final.event_times, event_initial=initial.event_times,
        event_sigmas=sigma[data.values.size:],
        event_sigmas_estimated=tuple(bool(np.isnan(s)) for s in data.event_sigmas),
        cost=float(0.5 * weighted @ weighted), iterations=int(iterations),
        evaluations=int(evaluations), runs=runs.count, rejected=tuple(runs.rejected),
        wall_time=time.perf_counter() - started, converged=solution.status > 0,
        status=solution.message, t_end=settings.t_end, dt_out=settings.dt_out,
        tol=settings.tol, sources=data.sources)


def _scales(free: Sequence[FreeParameter]) -> np.ndarray:
    """Each parameter's size for the trust region (x_scale) and the covariance's SVD: its
    start value's magnitude, else its bounds' width, else 1."""
    scales = []
    for f in free:
        width = f.high - f.low
        scales.append(abs(f.start) if f.start != 0 else width if np.isfinite(width) else 1.0)
    return np.array(scales, dtype=float)
