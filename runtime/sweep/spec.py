"""Study specifications: parameter grids and Monte Carlo samples, parsed by hand (never eval).

Grid items, full factorial over all of them (the first item varies slowest):

    NAME=START:STOP:N        N evenly spaced values from START to STOP inclusive

Sample items, `runs` draws each (numpy Generator, PCG64, seeded):

    NAME=normal(MU, SIGMA)
    NAME=uniform(A, B)
    NAME=lognormal(MEDIAN, SIGMA_LN)    ln(value) ~ normal(ln(MEDIAN), SIGMA_LN)
    NAME=triangular(A, MODE, B)

Numbers are plain SI floats ("1.5", "-2e-3"). A caller that knows the units of the model's
parameters may pass `quantity(name, text) -> float` to accept text such as "1.5 N*m" as well
(the facade does, via `Simulator.parameters`). With both a grid and samples, every grid point
gets the same `runs` samples (common random numbers): n_grid * runs runs in all, grid-major.

Each sampled parameter draws from its own stream, PCG64(SeedSequence(seed, spawn_key=(crc32 of
its name,))), so its numbers depend only on `seed`, its name and its distribution: adding or
reordering items leaves the other columns alone, and the first N draws of a study of 2N runs
are the draws of the study of N runs.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import re
import zlib
from collections.abc import Callable, Iterable, Mapping, Sequence

import numpy as np

__all__ = [
    "SweepSpecError", "GridAxis", "Distribution", "Design",
    "parse_grid", "parse_sample", "make_design", "MAX_RUNS",
]

MAX_RUNS = 10_000_000  # a guard against typos like 1e12 runs

Quantity = Callable[[str, str], float]


class SweepSpecError(ValueError):
    """A grid or sample specification the user wrote is wrong; the message names the bad part."""


@dataclasses.dataclass(frozen=True)
class GridAxis:
    """One grid item: `n` evenly spaced values from `start` to `stop` inclusive."""

    name: str
    start: float
    stop: float
    n: int
    text: str  # the item as written, for messages and the study's `spec` attribute

    def values(self) -> np.ndarray:
        return np.linspace(self.start, self.stop, self.n)

    def canonical(self) -> str:
        return f"{self.name}={_fmt(self.start)}:{_fmt(self.stop)}:{self.n}"


@dataclasses.dataclass(frozen=True)
class Distribution:
    """One sample item: `kind` is normal, uniform, lognormal or triangular; `args` in SI."""

    name: str
    kind: str
    args: tuple[float, ...]
    text: str

    def canonical(self) -> str:
        return f"{self.name}={self.kind}({', '.join(_fmt(a) for a in self.args)})"

    @property
    def mean(self) -> float:
        """The distribution's mean (SI)."""
        a = self.args
        return {"normal": lambda: a[0], "uniform": lambda: (a[0] + a[1]) / 2,
                "lognormal": lambda: a[0] * math.exp(a[1] ** 2 / 2),
                "triangular": lambda: sum(a) / 3}[self.kind]()

    @property
    def std(self) -> float:
        """The distribution's standard deviation (SI)."""
        a = self.args
        return {"normal": lambda: a[1], "uniform": lambda: (a[1] - a[0]) / math.sqrt(12),
                "lognormal": lambda: a[0] * math.sqrt(math.exp(a[1] ** 2)
                                                      * math.expm1(a[1] ** 2)),
                "triangular": lambda: math.sqrt(
                    (a[0] ** 2 + a[1] ** 2 + a[2] ** 2 - a[0] * a[1] - a[0] * a[2]
                     - a[1] * a[2]) / 18)}[self.kind]()

    def draw(self, seed: int, runs: int) -> np.ndarray:
        """`runs` draws from this parameter's own PCG64 stream (see the module docstring)."""
        stream = np.random.SeedSequence(seed, spawn_key=(zlib.crc32(self.name.encode()),))
        rng = np.random.Generator(np.random.PCG64(stream))
        a = self.args
        if self.kind == "normal":
            return a[0] + a[1] * rng.standard_normal(runs)
        if self.kind == "lognormal":
            return a[0] * np.exp(a[1] * rng.standard_normal(runs))
        u = rng.random(runs)
        if self.kind == "uniform":
            return a[0] + (a[1] - a[0]) * u
        if self.kind == "triangular":  # inverse CDF: one uniform per draw, no rejection
            lo, mode, hi = a
            split = (mode - lo) / (hi - lo)
            left = lo + np.sqrt(u * (hi - lo) * (mode - lo))
            right = hi - np.sqrt((1.0 - u) * (hi - lo) * (hi - mode))
            return np.where(u < split, left, right)
        raise AssertionError(self.kind)


# name -> (argument names, check(args) -> error text or None)
_KINDS: dict[str, tuple[tuple[str, ...], Callable[[tuple[float, ...]], str | None]]] = {
    "normal": (("MU", "SIGMA"), lambda a: "SIGMA must be >= 0" if a[1] < 0 else None),
    "uniform": (("A", "B"), lambda a: "needs A <= B" if a[0] > a[1] else None),
    "lognormal": (("MEDIAN", "SIGMA_LN"), lambda a: (
        "MEDIAN must be > 0 (it is the median exp(mu), not mu)" if a[0] <= 0 else
        "SIGMA_LN must be >= 0" if a[1] < 0 else None)),
    "triangular": (("A", "MODE", "B"), lambda a: (
        "needs A <= MODE <= B with A < B" if not (a[0] <= a[1] <= a[2] and a[0] < a[2])
        else None)),
}

# `h2.friction`, and names made by repetition: `panel[3].mass`, `cell[1][2].x` (docs/language.md)
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\[[0-9]+\])*(\.[A-Za-z_][A-Za-z0-9_]*(\[[0-9]+\])*)*\Z")
_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?\Z")
_CALL = re.compile(r"([A-Za-z_]+)\s*\((.*)\)\Z", re.S)


def _fmt(x: float) -> str:
    return repr(float(x))


def _split_item(item: str, what: str, example: str) -> tuple[str, str]:
    if not isinstance(item, str):
        raise SweepSpecError(f"{what} '{item!r}': expected text like '{example}'")
    name, sep, rhs = item.partition("=")
    name, rhs = name.strip(), rhs.strip()
    if not sep or not name or not rhs:
        raise SweepSpecError(f"{what} '{item}': expected NAME=..., e.g. '{example}'")
    if not _NAME.match(name):
        raise SweepSpecError(f"{what} '{item}': '{name}' is not a parameter name")
    return name, rhs


def _number(text: str, name: str, item: str, role: str, quantity: Quantity | None) -> float:
    text = text.strip()
    if not text:
        raise SweepSpecError(f"'{item}': {role} is missing")
    if _NUMBER.match(text):
        value = float(text)
    elif quantity is not None:
        try:
            value = float(quantity(name, text))
        except Exception as exc:  # the caller's unit check: its message says what is wrong
            raise SweepSpecError(f"'{item}': {role} '{text}': {exc}") from None
    else:
        raise SweepSpecError(f"'{item}': {role} '{text}' is not a plain number "
                             "(give SI values, e.g. 1.5 for 1.5 N*m)")
    if not math.isfinite(value):
        raise SweepSpecError(f"'{item}': {role} '{text}' is not a finite number")
    return value


def parse_grid(item: str, quantity: Quantity | None = None) -> GridAxis:
    """Parse 'NAME=START:STOP:N'. Raises SweepSpecError naming the bad part."""
    example = "h2.friction=0.5:0.9:5"
    name, rhs = _split_item(item, "grid", example)
    parts = rhs.split(":")
    if len(parts) != 3:
        raise SweepSpecError(f"grid '{item}': expected NAME=START:STOP:N, e.g. '{example}' "
                             f"(found {len(parts)} ':'-separated part{'s' * (len(parts) != 1)})")
    start = _number(parts[0], name, item, "START", quantity)
    stop = _number(parts[1], name, item, "STOP", quantity)
    count = parts[2].strip()
    if not count.isdigit() or int(count) < 1:
        raise SweepSpecError(f"grid '{item}': N '{count}' must be a positive integer "
                             "(the number of values)")
    n = int(count)
    if n == 1 and start != stop:
        raise SweepSpecError(f"grid '{item}': N is 1 but START != STOP; use N >= 2 "
                             "or START = STOP")
    return GridAxis(name, start, stop, n, item)


def parse_sample(item: str, quantity: Quantity | None = None) -> Distribution:
    """Parse 'NAME=normal(MU,SIGMA)' and friends. Raises SweepSpecError naming the bad part."""
    example = "h2.friction=normal(0.64, 0.05)"
    name, rhs = _split_item(item, "sample", example)
    call = _CALL.match(rhs)
    known = ", ".join(f"{k}({', '.join(v[0])})" for k, v in _KINDS.items())
    if not call:
        raise SweepSpecError(f"sample '{item}': '{rhs}' is not a distribution; use one of "
                             f"{known}")
    kind = call.group(1).lower()
    if kind not in _KINDS:
        close = difflib.get_close_matches(kind, list(_KINDS), n=1)
        hint = f" (did you mean '{close[0]}'?)" if close else ""
        raise SweepSpecError(f"sample '{item}': unknown distribution '{call.group(1)}'{hint}; "
                             f"use one of {known}")
    roles, check = _KINDS[kind]
    body = call.group(2)
    if "(" in body or ")" in body:
        raise SweepSpecError(f"sample '{item}': arguments must be numbers, not expressions")
    raw = body.split(",")
    if len(raw) != len(roles) or not body.strip():
        raise SweepSpecError(f"sample '{item}': {kind} takes {len(roles)} arguments "
                             f"{kind}({', '.join(roles)}), got "
                             f"{0 if not body.strip() else len(raw)}")
    unitless = {"SIGMA_LN"}  # a shape, not a value of the parameter
    args = tuple(_number(text, name, item, role, None if role in unitless else quantity)
                 for text, role in zip(raw, roles))
    problem = check(args)
    if problem:
        raise SweepSpecError(f"sample '{item}': {kind}({', '.join(roles)}) {problem}")
    return Distribution(name, kind, args, item)


@dataclasses.dataclass(frozen=True, eq=False)
class Design:
    """What a study runs: one full parameter vector per run, and how they were made.

    matrix[i] is the parameter vector of run i, in the layout `parameter_names` (the generated
    module's PARAMETERS). `varied` names the grid and sample parameters, in spec order."""

    parameter_names: tuple[str, ...]
    matrix: np.ndarray  # (runs, NP) float64
    varied: tuple[str, ...]
    grid: tuple[GridAxis, ...] = ()
    samples: tuple[Distribution, ...] = ()
    seed: int | None = None
    sample_runs: int | None = None  # Monte Carlo draws per grid point

    @property
    def runs(self) -> int:
        return int(self.matrix.shape[0])

    @property
    def kind(self) -> str:
        return {(True, False): "grid", (False, True): "monte_carlo",
                (True, True): "grid x monte_carlo"}.get((bool(self.grid), bool(self.samples)),
                                                         "single")

    @property
    def spec(self) -> str:
        """The canonical text of the study: grid items, sample items, runs and seed."""
        parts = [f"grid {g.canonical()}" for g in self.grid]
        parts += [f"sample {s.canonical()}" for s in self.samples]
        if self.samples:
            parts += [f"runs={self.sample_runs}", f"seed={self.seed}"]
        return "; ".join(parts)

    def values(self, name: str) -> np.ndarray:
        return self.matrix[:, self.parameter_names.index(name)]


def _items(spec, what: str) -> list[str]:
    """Accept a string, a list of strings, or a mapping name -> text (or (start, stop, n))."""
    if spec is None:
        return []
    if isinstance(spec, str):
        return [spec]
    if isinstance(spec, Mapping):
        out = []
        for name, value in spec.items():
            if what == "grid" and isinstance(value, (tuple, list)):
                if len(value) != 3:
                    raise SweepSpecError(f"grid '{name}': expected (START, STOP, N), got {value!r}")
                value = ":".join(str(v) for v in value)
            out.append(f"{name}={value}")
        return out
    if isinstance(spec, Iterable):
        return list(spec)
    raise SweepSpecError(f"{what}: expected text like 'NAME=...', got {spec!r}")


def make_design(parameter_names: Sequence[str], defaults: Sequence[float], *,
                grid=None, samples=None, runs: int | None = None, seed: int | None = None,
                quantity: Quantity | None = None) -> Design:
    """Build the run matrix from grid and sample items (strings, lists, or name->text maps).

    Parameters not varied keep `defaults`. With samples, `runs` (> 0) draws are made; `seed`
    None picks a fresh one from the OS, recorded in the design so the study can be repeated.
    Raises SweepSpecError for unknown parameters, duplicates, bad items or a bad runs/seed."""
    names = tuple(str(n) for n in parameter_names)
    defaults = np.asarray(defaults, dtype=float)
    if defaults.shape != (len(names),):
        raise ValueError(f"defaults has shape {defaults.shape}, expected ({len(names)},)")
    axes = [parse_grid(i, quantity) if isinstance(i, str) else _bad(i, "grid")
            for i in _items(grid, "grid")]
    dists = [parse_sample(i, quantity) if isinstance(i, str) else _bad(i, "sample")
             for i in _items(samples, "sample")]
    seen: dict[str, str] = {}
    for entry in [*axes, *dists]:
        if entry.name not in names:
            close = difflib.get_close_matches(entry.name, names, n=1)
            hint = f"; did you mean '{close[0]}'?" if close else ""
            listed = ", ".join(names) if len(names) <= 12 else f"{len(names)} parameters"
            raise SweepSpecError(f"'{entry.text}': unknown parameter '{entry.name}'{hint} "
                                 f"(this model has: {listed})")
        if entry.name in seen:
            raise SweepSpecError(f"'{entry.text}': parameter '{entry.name}' is already varied "
                                 f"by '{seen[entry.name]}'; vary each parameter once")
        seen[entry.name] = entry.text
    if runs is not None:
        if isinstance(runs, bool) or not isinstance(runs, (int, np.integer)) or runs < 1:
            raise SweepSpecError(f"runs {runs!r}: must be a positive integer")
        runs = int(runs)
    if dists and runs is None:
        raise SweepSpecError("samples need a run count: give runs=N (--runs N)")
    if not dists and runs is not None and runs != 1:
        raise SweepSpecError(f"runs={runs} without any sample item: a grid runs each point "
                             "once; add --sample items or drop --runs")
    if seed is not None:
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
            raise SweepSpecError(f"seed {seed!r}: must be a non-negative integer")
        seed = int(seed)
    elif dists:
        seed = int(np.random.SeedSequence().entropy % (2**63))
    n_grid = math.prod(a.n for a in axes)
    n_samples = runs if dists else 1
    total = n_grid * n_samples
    if total > MAX_RUNS:
        raise SweepSpecError(f"the study has {total} runs (grid {n_grid} x samples "
                             f"{n_samples}); more than {MAX_RUNS} is surely a typo")
    matrix = np.tile(defaults, (total, 1))
    if axes:
        mesh = np.meshgrid(*[a.values() for a in axes], indexing="ij")
        for axis, values in zip(axes, mesh):
            matrix[:, names.index(axis.name)] = np.repeat(values.ravel(), n_samples)
    for dist in dists:
        matrix[:, names.index(dist.name)] = np.tile(dist.draw(seed, n_samples), n_grid)
    return Design(names, matrix, tuple(e.name for e in [*axes, *dists]), tuple(axes),
                  tuple(dists), seed if dists else None, runs if dists else None)


def _bad(item, what: str):
    raise SweepSpecError(f"{what} {item!r}: expected text like 'NAME=...'")
