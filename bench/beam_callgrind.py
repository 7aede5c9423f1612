"""Where a linearly implicit two_link_flex run of depsim's standalone program spends its
instructions, by the method's parts (docs/method.md, 10) and by kind of work: one run under
valgrind's callgrind (deterministic instruction counts, whatever else the machine runs), read
through callgrind_annotate's caller tree. bench/bench_exudyn.py --profile calls it.

The parts are named by the core's functions (runtime/c); a part whose function is not found
(the core renamed it) prints as such.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

# The method's parts in a linearly implicit run (docs/method.md, 10) by the core's functions:
# (label, function, caller or None: the function's inclusive instructions from that caller
# only). A part not found (the core renamed it) prints as such.
PARTS = [
    ("the whole process", "main", None),
    ("  start, setup and writing the CSV (outside dep_run_until)", None, None),
    ("  the steps (dep_step: every trial step)", "dep_step", None),
    ("    integration: ROS34PW2 stages (dep_rosenbrock_step)", "dep_rosenbrock_step", None),
    ("      force evaluations (dep_stepper_stage_force)", "dep_stepper_stage_force",
     "dep_rosenbrock_step"),
    ("      stage solves: W solves and T products (solve_stage)", "solve_stage",
     "dep_rosenbrock_step"),
    ("    passes beyond the integration (dep_iterate_multipliers less it)", "PASSES", None),
    ("      linear moves of the position pass (dep_stepper_respond)", "dep_stepper_respond",
     None),
    ("      acceleration pass (measure_acceleration)", "measure_acceleration", None),
    ("      velocity pass (measure_velocity)", "measure_velocity", None),
    ("      Schur solves and forms (step_for)", "step_for", None),
    ("    acceleration at the step's end (dep_acceleration)", "dep_acceleration", None),
    ("    K and D each step, drift check, new W's factor (dep_implicit_prepare)",
     "dep_implicit_prepare", None),
    ("      K and D evaluations (model_stiffness)", "model_stiffness", "dep_implicit_prepare"),
    ("      W factorisations (dep_envelope_factor)", "dep_envelope_factor",
     "dep_implicit_prepare"),
    ("      drift bounds (drift_bounds)", "drift_bounds", None),
    ("    a new W's unit responses (dep_stepper_unit_responses)",
     "dep_stepper_unit_responses", None),
    ("    the profile's multipliers (dep_stepper_history_multipliers)",
     "dep_stepper_history_multipliers", None),
    ("      a new W's filter (filter_block)", "filter_block", None),
    ("  tangential projections (dep_stepper_tangential)", "dep_stepper_tangential", None),
    ("  after each step: outputs, loads (dep_run_after_step)", "dep_run_after_step", None),
]
# cross-cutting: the kinds of work, wherever they are called from
KINDS = [
    ("model force (model_force)", "model_force"),
    ("model stiffness K, D (model_stiffness)", "model_stiffness"),
    ("envelope solves with W (dep_envelope_solve_block)", "dep_envelope_solve_block"),
    ("envelope solves with M (dep_mass_solve)", "dep_mass_solve"),
    ("T products (envelope_subtract)", "envelope_subtract"),
    ("envelope products (dep_envelope_times)", "dep_envelope_times"),
    ("Phi_q^T lambda and its responses (dep_multipliers_apply)", "dep_multipliers_apply"),
    ("memcpy, memset", "__memcpy_avx_unaligned_erms"),
]


def callgrind(cmd: list[str], folder: Path) -> tuple[dict, dict, dict] | None:
    """Inclusive instructions and calls per function, and per (function, caller), of one run
    under callgrind; None without valgrind."""
    if shutil.which("valgrind") is None or shutil.which("callgrind_annotate") is None:
        return None
    out = folder / "callgrind.out"
    subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", *cmd],
                   check=True, capture_output=True)
    text = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--tree=caller",
                           "--threshold=100", str(out)], check=True, capture_output=True,
                          text=True).stdout
    inclusive, calls, by_caller, callers = {}, {}, {}, []
    for line in text.splitlines():
        found = re.match(r"\s*([\d,]+) \([\s\d.]+%\)\s+([*<])\s+(\S+)(?: \(([\d,]+)x\))?",
                         line)
        if not found:
            continue
        value, kind, where, count = found.groups()
        function = where.rsplit(":", 1)[-1]
        value = int(value.replace(",", ""))
        if kind == "<":
            callers.append((function, value, int(count.replace(",", "")) if count else 0))
            continue
        inclusive[function] = max(inclusive.get(function, 0), value)
        calls[function] = sum(n for _, _, n in callers)
        for caller, v, n in callers:
            by_caller[function, caller] = (v, n)
        callers = []
    return inclusive, calls, by_caller


def row(label: str, value: int | None, n: int, total: int, steps: int) -> None:
    """One part's line: its share of the instructions, its calls, per call and per step."""
    if value is None:
        print(f"{label:<78} {'not found':>6}")
        return
    per_call = f"{value / n:10,.0f}" if n else f"{'':>10}"
    print(f"{label:<78} {100 * value / total:5.1f}% {n:>8} {per_call} {value / steps:9,.0f}")


def profile(cmd: list[str], folder: Path, steps: int) -> None:
    found = callgrind(cmd, folder)
    if found is None:
        print("\nno valgrind on this machine: no profile")
        return
    inclusive, calls, by_caller = found
    total = inclusive.get("main", max(inclusive.values()))
    inclusive["PASSES"] = (inclusive.get("dep_iterate_multipliers", 0)
                           - by_caller.get(("dep_rosenbrock_step", "measure_position"),
                                           (0, 0))[0])
    print(f"\ndepsim's run by the method's parts (callgrind, inclusive instructions; {steps} "
          f"steps, {total / steps:,.0f} instructions a step)")
    print(f"{'part':<78} {'share':>6} {'calls':>8} {'per call':>10} {'per step':>9}")
    for label, function, caller in PARTS:
        if function is None:  # outside the run's loop over the steps
            value, n = total - inclusive.get("dep_run_until", total), 0
        elif caller is not None:
            value, n = by_caller.get((function, caller), (None, 0))
        else:
            value, n = inclusive.get(function), calls.get(function, 0)
        row(label, value, n, total, steps)
    print("\nthe same by kind of work, wherever it is called")
    for label, function in KINDS:
        row(label, inclusive.get(function), calls.get(function, 0), total, steps)
