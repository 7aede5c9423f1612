"""A fit's result (`FitResult`, made by depsim.runtime.fit): the estimates, their standard
errors and correlations from the Jacobian at the optimum, which parameters the data cannot
determine, the residuals; its report, JSON and figure (docs/calibration.md)."""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np

from .output import atomic_path

# A singular value of the scaled, weighted Jacobian below RCOND times the largest is taken as
# zero: the sensitivities are exact to about the integration tolerance (1e-8 .. 1e-6
# relative), so a direction so much flatter cannot be told from a flat one. (cable_k and
# pulley_r of INTELSAT V, which enter as cable_k * pulley_r^2 alone, give 5e-16.)
RCOND = 1e-6
NULL_SHARE = 0.01  # a parameter whose share in a flat direction exceeds this is not identifiable
STRONG = 0.99  # |correlation| from which a parameter is reported as weakly determined


@dataclass(frozen=True)
class Uncertainty:
    """What the Jacobian at the optimum says of the estimates: standard errors (inf where not
    identifiable), correlations, which parameters are identifiable, the singular values of
    the Jacobian scaled by the parameters' sizes (largest first)."""

    standard_errors: np.ndarray
    correlation: np.ndarray
    identifiable: tuple[bool, ...]
    singular_values: np.ndarray
    flat: np.ndarray  # (d, k) the flat directions, in scaled parameters

    def notes(self, names: tuple[str, ...]) -> tuple[str, ...]:
        """Per parameter: why it is not identifiable or weakly determined, else ""."""
        found = []
        for j, name in enumerate(names):
            others = [i for i in range(len(names)) if i != j]
            if not self.identifiable[j]:
                partners = [names[i] for i in others
                            if np.any(np.abs(self.flat[:, [i, j]]).min(axis=1) > NULL_SHARE)]
                why = (f"they fix only its combination with {', '.join(partners)} "
                       f"({_strongest(self.correlation[j], others, names)})"
                       if partners else "they do not depend on it")
                found.append(f"not identifiable from these data: {why}")
            elif others and np.abs(self.correlation[j, others]).max() >= STRONG:
                found.append(f"weakly determined: {_strongest(self.correlation[j], others, names)}"
                             "; the data fix mostly their combination")
            else:
                found.append("")
        return tuple(found)


def _strongest(row: np.ndarray, others: list[int], names) -> str:
    i = max(others, key=lambda o: abs(row[o]))
    return f"correlation {row[i]:+.4f} with {names[i]}"


def uncertainty(jacobian: np.ndarray, scale: np.ndarray) -> Uncertainty:
    """The covariance (J^T J)^-1 of the estimates, J the weighted Jacobian (N, k), through the
    SVD of J scaled by the parameters' sizes `scale` (k,), so a singular J^T J does not fail:
    a flat direction (singular value below RCOND of the largest) gives its parameters an
    infinite standard error, and the correlations its sign (computed with the flat singular
    values raised to RCOND of the largest)."""
    k = jacobian.shape[1]
    rows = np.zeros((max(k - len(jacobian), 0), k))  # fewer values than parameters: flat too
    _, s, vt = np.linalg.svd(np.vstack((jacobian * scale, rows)), full_matrices=False)
    top = s[0] if len(s) and s[0] > 0 else 1.0
    flat = s <= RCOND * top
    floored = np.maximum(s, RCOND * top)
    covariance = (vt.T / floored ** 2) @ vt * np.outer(scale, scale)
    spread = np.sqrt(np.diag(covariance))
    identifiable = ~np.any(np.abs(vt[flat]) > NULL_SHARE, axis=0)
    errors = np.where(identifiable, spread, np.inf)
    return Uncertainty(errors, covariance / np.outer(spread, spread),
                       tuple(bool(b) for b in identifiable), s, vt[flat])


@dataclass(frozen=True)
class FitResult:
    """A fit of a model to measurements. Shapes: k free parameters, n measured times, m
    measured columns, e measured events. SI throughout."""

    model: str
    parameters: tuple[str, ...]  # (k,) the free parameters
    units: tuple[str, ...]  # (k,) their units
    start: np.ndarray  # (k,) start values
    bounds: np.ndarray  # (k, 2) low, high (-inf, inf: none)
    estimates: np.ndarray  # (k,)
    standard_errors: np.ndarray  # (k,) inf: not identifiable from these data
    correlation: np.ndarray  # (k, k)
    identifiable: tuple[bool, ...]  # (k,)
    notes: tuple[str, ...]  # (k,) not identifiable / weakly determined and why, else ""
    singular_values: np.ndarray  # (k,) of the weighted Jacobian scaled by the parameters' sizes
    columns: tuple[str, ...]  # (m,) measured outputs
    column_units: tuple[str, ...]  # (m,)
    times: np.ndarray  # (n,) s
    measured: np.ndarray  # (n, m)
    fitted: np.ndarray  # (n, m) the model at the estimates
    initial: np.ndarray  # (n, m) the model at the start
    sigmas: np.ndarray  # (m,) each column's noise, given or estimated
    sigmas_estimated: tuple[bool, ...]  # (m,)
    events: tuple[str, ...]  # (e,) measured events ("h1.latch")
    event_measured: np.ndarray  # (e,) s
    event_fitted: np.ndarray  # (e,) s
    event_initial: np.ndarray  # (e,) s
    event_sigmas: np.ndarray  # (e,) s
    event_sigmas_estimated: tuple[bool, ...]  # (e,)
    cost: float  # half the sum of the squared weighted residuals
    iterations: int  # Jacobian evaluations of the least squares
    evaluations: int  # residual evaluations
    runs: int  # model runs (a point's residuals and Jacobian share one)
    wall_time: float  # s
    rejected: tuple[str, ...]  # trial points rejected: an event missed, refused, run failed
    converged: bool
    status: str  # the least squares' termination
    t_end: float  # s, of the runs
    dt_out: float  # s, of the runs
    tol: float | None
    sources: tuple[str, ...] = ()

    @property
    def intervals(self) -> np.ndarray:
        """(k, 2) estimate -+ 2 standard errors ((-inf, inf) where not identifiable)."""
        return np.column_stack((self.estimates - 2 * self.standard_errors,
                                self.estimates + 2 * self.standard_errors))

    @property
    def residuals(self) -> dict[str, np.ndarray]:
        """Model minus measured: each column's (n,), and "events" (e,) s."""
        found = {c: self.fitted[:, j] - self.measured[:, j] for j, c in enumerate(self.columns)}
        found["events"] = self.event_fitted - self.event_measured
        return found

    def rms(self) -> dict[str, float]:
        """The residuals' root mean square: per column, and for the events."""
        return {name: float(np.sqrt(np.mean(r ** 2))) if len(r) else float("nan")
                for name, r in self.residuals.items()}

    def summary(self) -> dict:
        """The fit as plain JSON-ready data (docs/calibration.md, The JSON file)."""
        rms = self.rms()
        return {
            "model": self.model,
            "data": list(self.sources),
            "parameters": {name: {
                "unit": self.units[j], "start": float(self.start[j]),
                "bounds": [_number(b) for b in self.bounds[j]],
                "estimate": float(self.estimates[j]),
                "standard_error": _number(self.standard_errors[j]),
                "interval_2sigma": [_number(v) for v in self.intervals[j]],
                "identifiable": self.identifiable[j], "note": self.notes[j]}
                for j, name in enumerate(self.parameters)},
            "correlation": {"parameters": list(self.parameters),
                            "matrix": [[float(v) for v in row] for row in self.correlation]},
            "residuals": {c: {"unit": self.column_units[j], "n": len(self.times),
                              "rms": rms[c], "sigma": float(self.sigmas[j]),
                              "sigma_estimated": self.sigmas_estimated[j]}
                          for j, c in enumerate(self.columns)},
            "events": [{"event": name, "measured": float(self.event_measured[i]),
                        "fitted": float(self.event_fitted[i]),
                        "start": float(self.event_initial[i]),
                        "residual": float(self.event_fitted[i] - self.event_measured[i]),
                        "sigma": float(self.event_sigmas[i]),
                        "sigma_estimated": self.event_sigmas_estimated[i]}
                       for i, name in enumerate(self.events)],
            "events_rms": _number(rms["events"]),
            "cost": self.cost, "iterations": self.iterations,
            "evaluations": self.evaluations, "runs": self.runs, "wall_time": self.wall_time,
            "rejected": list(self.rejected),
            "converged": self.converged, "status": self.status,
            "singular_values": [float(s) for s in self.singular_values],
            "settings": {"t_end": self.t_end, "dt_out": self.dt_out, "tol": self.tol},
        }

    def to_json(self, path) -> None:
        """The `summary()` as JSON, written atomically."""
        with atomic_path(path) as tmp, open(tmp, "w", encoding="utf-8") as handle:
            handle.write(json.dumps(self.summary(), indent=2) + "\n")

    def plot(self, path) -> None:
        """Measured, fitted and start values per column with the residuals below
        (depsim.runtime.fit_figure), in the format of the extension of `path`."""
        from .fit_figure import plot_fit

        plot_fit(self, path)

    def report(self) -> str:
        """The fit in lines: what was fitted and how it ended, the estimates, the
        correlations, the residuals."""
        lines = [f"fit of {self.model} to {', '.join(self.sources)}: "
                 f"{self.measured.size} values in {len(self.columns)} column(s), "
                 f"{len(self.events)} event time(s)",
                 f"  {'converged' if self.converged else 'NOT converged'}: {self.status}",
                 f"  {self.iterations} iterations, {self.evaluations} evaluations, "
                 f"{self.runs} runs with {len(self.parameters)} sensitivities "
                 f"(dt_out {self.dt_out:g} s, t_end {self.t_end:g} s), "
                 f"{self.wall_time:.2f} s; cost {self.cost:.6g}"]
        if self.rejected:
            lines.append(f"  {len(self.rejected)} trial point(s) rejected (a measured event "
                         "missed, values the model refuses or a run that failed); the first: "
                         f"{self.rejected[0]}")
        lines.append("")
        lines += _parameter_table(self)
        lines += ["", "correlation:"] + _correlation_table(self.parameters, self.correlation)
        lines += ["", "residuals (model - measured):"] + _residual_table(self)
        return "\n".join(lines)


def _parameter_table(fit: FitResult) -> list[str]:
    width = max(len("parameter"), *map(len, fit.parameters))
    rows = [f"  {'parameter':<{width}}  {'start':>11}  {'estimate':>11}  {'std error':>10}  "
            f"{'2-sigma interval':>25}  unit"]
    for j, name in enumerate(fit.parameters):
        low, high = fit.intervals[j]
        interval = (f"[{low:.6g}, {high:.6g}]" if fit.identifiable[j] else "none")
        rows.append(f"  {name:<{width}}  {fit.start[j]:>11.6g}  {fit.estimates[j]:>11.6g}  "
                    f"{fit.standard_errors[j]:>10.3g}  {interval:>25}  {fit.units[j]}")
        if fit.notes[j]:
            rows.append(f"  {'':<{width}}  ^ {fit.notes[j]}")
    return rows


def _correlation_table(names: tuple[str, ...], correlation: np.ndarray) -> list[str]:
    width = max(10, *map(len, names))
    head = "  " + " " * width + "".join(f"  {n:>{width}}" for n in names)
    return [head] + [f"  {n:<{width}}" + "".join(f"  {v:>+{width}.4f}" for v in row)
                     for n, row in zip(names, correlation)]


def _residual_table(fit: FitResult) -> list[str]:
    rms = fit.rms()
    rows = [f"  {'column':<12}  {'n':>7}  {'rms':>11}  {'sigma':>11}  unit"]
    for j, column in enumerate(fit.columns):
        kind = "estimated" if fit.sigmas_estimated[j] else "given"
        rows.append(f"  {column:<12}  {len(fit.times):>7}  {rms[column]:>11.4g}  "
                    f"{fit.sigmas[j]:>11.4g}  {fit.column_units[j] or '1'} (sigma {kind})")
    if len(fit.events):
        kind = "estimated" if any(fit.event_sigmas_estimated) else "given"
        rows.append(f"  {'event times':<12}  {len(fit.events):>7}  {rms['events']:>11.4g}  "
                    f"{float(np.max(fit.event_sigmas)):>11.4g}  s (sigma {kind})")
        for i, name in enumerate(fit.events):
            rows.append(f"    {name}: measured {fit.event_measured[i]:.6g} s, fitted "
                        f"{fit.event_fitted[i]:.6g} s, start {fit.event_initial[i]:.6g} s")
    return rows


def _number(value: float) -> float | None:
    """A float, None for inf or NaN (standard JSON)."""
    return float(value) if np.isfinite(value) else None
