"""Compare a run's CSV and summary with a stored one by what the method determines.

Two runs of the same model and settings whose arithmetic differs in round-off alone (another
CPU's fused multiply-add, another libm, a moved function) take other steps once an error
estimate crosses a threshold, so their numbers part by about what the step control leaves:
the run's tol (measured, the core built with and without -mfma: 1e-4 tol on the pendulum,
slider-crank and four-bar, whose steps do not move; up to 1.2 tol on INTELSAT V's and the
accordion's angles, whose latches move them; 87 tol on the flexible links' elastic tip, whose
stiff modes the linearly implicit step damps). A change of the method moves them by its
global error instead: INTELSAT V at tol 1e-8 and at 1e-7 part by 4.9e-7 rad, 49 tol. So:

* outputs, at every output time: |y - y_stored| <= FACTOR tol, in the outputs' SI units (rad,
  m: all of order one in the examples);
* latch times: |t - t_stored| <= FACTOR tol / |rate|, the angle's bound carried to the time
  at the latch's rate; the latches' order, rigidity and the deployed flag exactly; their
  rates, impulses and energies lost, and the energies dissipated, within FACTOR tol of their
  scale;
* peak loads: the largest at the accepted steps, so a sharp peak between steps is sampled
  elsewhere when the steps move (by up to f'' h^2 / 8): within PEAK tol of the largest.

Step counts, the times of flat maxima and the last digits are not determined by the method
and are not compared.
"""

from __future__ import annotations

import csv
import gzip
import io
import json
from pathlib import Path

STORED = Path(__file__).resolve().parents[1] / "golden" / "examples"
FACTOR = 10.0  # tolerances
PEAK = 1e4     # tolerances of the largest load


def read_csv(text: str) -> tuple[list[str], list[list[float]]]:
    rows = list(csv.reader(io.StringIO(text)))
    return rows[0], [[float(v) for v in row] for row in rows[1:]]


def stored(name: str) -> tuple[str, dict]:
    """The stored CSV text and summary of example `name`."""
    text = gzip.decompress((STORED / f"{name}.csv.gz").read_bytes()).decode()
    return text, json.loads((STORED / f"{name}.json").read_text())


def output_differences(text: str, reference: str, tol: float,
                       loads: tuple[str, ...] = ()) -> list[str]:
    """Columns whose values leave the bound, as messages. The columns named in `loads` are
    joint loads through a latch's contact, compared as peak loads are (within PEAK tol of
    their largest): a compliant latch's contact moves by about tol / rate when the steps move,
    and its load changes at the latch stiffness's rate there."""
    header, rows = read_csv(text)
    header_ref, rows_ref = read_csv(reference)
    if header != header_ref or len(rows) != len(rows_ref):
        return [f"columns {header} / {header_ref}, rows {len(rows)} / {len(rows_ref)}"]
    problems = []
    for k, name in enumerate(header):
        column = [row[k] for row in rows]
        column_ref = [row[k] for row in rows_ref]
        bound = FACTOR * tol
        if name in loads:
            bound = PEAK * tol * max(abs(value) for value in column_ref)
        worst = max(abs(a - b) for a, b in zip(column, column_ref))
        if not worst <= bound:
            problems.append(f"{name}: differs by {worst:.3g} > {bound:.3g}")
    return problems


def summary_differences(summary: dict, reference: dict, tol: float) -> list[str]:
    """Deployment and peak-load differences beyond the bounds, as messages."""
    problems = []
    d, d_ref = summary["deployment"], reference["deployment"]
    if d["deployed"] != d_ref["deployed"] or d["latch_hinges"] != d_ref["latch_hinges"]:
        return [f"deployed {d['deployed']} / {d_ref['deployed']}"]
    order = [(latch["hinge"], latch["rigid"]) for latch in d["latches"]]
    if order != [(latch["hinge"], latch["rigid"]) for latch in d_ref["latches"]]:
        return [f"latches {order}"]
    impulse_scale = max([abs(x["impulse"]) for x in d_ref["latches"] if x["impulse"]] + [0.0])
    energy_scale = max([d_ref["friction_energy"], d_ref["impact_energy"]]
                       + [x["energy_loss"] or 0.0 for x in d_ref["latches"]])
    for latch, ref in zip(d["latches"], d_ref["latches"]):
        slack = FACTOR * tol / max(abs(ref["rate"]), 1e-300)
        close(problems, f"{ref['hinge']} latch time", latch["t"], ref["t"], slack)
        close(problems, f"{ref['hinge']} latch rate", latch["rate"], ref["rate"],
              FACTOR * tol * (1.0 + abs(ref["rate"])))
        if ref["impulse"] is not None:
            close(problems, f"{ref['hinge']} impulse", latch["impulse"], ref["impulse"],
                  FACTOR * tol * (1.0 + impulse_scale))
            close(problems, f"{ref['hinge']} energy lost", latch["energy_loss"],
                  ref["energy_loss"], FACTOR * tol * (1.0 + energy_scale))
    for key in ("friction_energy", "impact_energy"):
        close(problems, key, d[key], d_ref[key], FACTOR * tol * (1.0 + energy_scale))
    peaks, peaks_ref = summary["peak_hinge_loads"], reference["peak_hinge_loads"]
    for kind in ("force", "torque"):
        scale = max([p[kind] for p in peaks_ref.values()] + [0.0])
        for hinge, ref in peaks_ref.items():
            close(problems, f"{hinge} peak {kind}", peaks[hinge][kind], ref[kind],
                  PEAK * tol * (1.0 + scale))
    return problems


def close(problems: list[str], what: str, value: float, reference: float, bound: float):
    if not abs(value - reference) <= bound:
        problems.append(f"{what}: {value!r} against {reference!r} (bound {bound:.3g})")
