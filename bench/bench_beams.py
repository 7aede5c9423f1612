"""The two-link flexible pendulum (docs/examples.md, two flexible links) at 2, 4, 8, 16 elements per link: cost of the
iterative integrator, energy conservation, and mesh convergence of chord2 and tip2.

    .venv/bin/python bench/bench_beams.py [--span 0.1] [--elements 2,4,8,16] [--tol 1e-8]
                                          [--energy-span 5] [--cantilever 8] [--save F.npz]

Every run goes through the real pipeline: examples/two_link_flex.dep -> Model.with_elements ->
compile(target="numpy" or, with --target c, "c") -> the iterative integrator.

1. Cost: wall time per simulated second, accepted / rejected / retried steps, step sizes and
   the mean iterations of (6) per step of each pass. The links' axial modes (omega_max =
   6.5e4 rad/s at 2 elements, growing like n; docs/beams.md) bound the explicit step, so a
   simulated second is expensive, and more so with more elements.
2. Energy: kinetic + gravity + elastic (the generated `energy`) is constant for this undamped
   model; the drift max |E(t) - E(0)| is printed in J and relative to the largest kinetic energy
   of the run. `--energy-span 5` also integrates the 2-element model over the paper's full 5 s.
3. Convergence: chord2 and tip2 on the common output grid for each element count; the table
   gives their values at the end of the span and the largest difference over the span to the
   next coarser mesh (they should shrink as the mesh is refined), raw and after a moving
   average over one period of link 2's first bending mode. The raw differences are those of
   the high-frequency bending waves the release excites, whose phase drifts with the mesh; the
   smoothed ones are those of the swing and the quasi-static bending (the paper's Figures 4, 5).
4. `--cantilever N`: a clamped beam (EI = 100 N m^2, 1 kg/m, L = 1 m) with N elements
   released in gravity, integrated over 2.5 periods; its first bending frequency, fitted to
   the tip deflection, against beam theory (tests/codegen/test_beam_system.py does this with
   four elements).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import optimize, signal

import depsim
from beam_reference import reference_path

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "examples" / "two_link_flex.dep"
OUTPUTS = ("chord2", "tip2")
# one period of link 2's first bending mode in M2 (about 283 rad/s): the window of the
# smoothed differences, which leave out the bending waves the release excites
SMOOTHING = 2 * np.pi / 283.0  # s
LOW_PASS = 60.0  # Hz: the accuracy bar's low-pass of tip2 (link 2's first mode is 45 Hz)
CANTILEVER_ROOTS = (1.8751040687119611, 4.6940911329741746)  # cos b cosh b = -1
CANTILEVER = """\
model cantilever
gravity = (0, -9.81) m/s^2
beam arm {{ length = 1 m; EI = 100 N*m^2; EA = 1e4 N; mass_per_length = 1 kg/m; elements = {n} }}
slider clamp joins ground.origin to arm.a {{ axis = (1, 0) }}
simulate {{ t_end = 0.45 s; tol = 1e-6; dt_out = 0.001 s }}
output deflection = arm.tip_deflection
"""


@dataclass(frozen=True)
class Run:
    """One run of M2 with `elements` elements per link."""

    elements: int
    span: float
    compile_seconds: float
    run_seconds: float
    result: object  # depsim.runtime.Result

    @property
    def seconds_per_second(self) -> float:
        return self.run_seconds / self.span

    def energy_drift(self) -> tuple[float, float]:
        """(max |E(t) - E(0)| in J, the same over the largest kinetic energy of the run)."""
        total = self.result.total_energy()
        drift = float(np.max(np.abs(total - total[0])))
        kinetic = self.result.energy[:, self.result.energy_names.index("kinetic")]
        return drift, drift / float(np.max(kinetic))


def run_m2(elements: int, span: float, tol: float, dt_out: float, out_dir: Path,
           target: str = "numpy", stepping: str = "auto") -> Run:
    """Compile M2 with `elements` per link into out_dir and integrate it over [0, span] s."""
    start = time.perf_counter()
    model = depsim.load(MODEL).with_elements({"link1": elements, "link2": elements})
    sim = model.compile(target=target, out_dir=out_dir / f"{target}{elements}")
    compiled = time.perf_counter()
    # fine meshes over seconds take millions of explicit steps on purpose (docs/beams.md)
    result = sim.run(t_end=span, dt_out=dt_out, tol=tol, max_steps=1e9, stepping=stepping)
    done = time.perf_counter()
    return Run(elements, span, compiled - start, done - compiled, result)


def cost_table(runs: list[Run]) -> str:
    lines = ["| elements/link | NQ | compile s | run s | s per simulated s | accepted "
             "| rejected | retried | h min..max (s) | iterations/step pos, vel, acc "
             "| energy drift J (rel. KE) |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for run in runs:
        s = run.result.stats
        drift, relative = run.energy_drift()
        lines.append(
            f"| {run.elements} | {len(run.result.coordinate_names)} | {run.compile_seconds:.1f} "
            f"| {run.run_seconds:.2f} | {run.seconds_per_second:.2f} | {s.accepted_steps} "
            f"| {s.rejected_steps} | {s.failed_steps} | {s.min_step:.1e}..{s.max_step:.1e} "
            f"| {s.position.mean:.2f}, {s.velocity.mean:.2f}, {s.acceleration.mean:.2f} "
            f"| {drift:.1e} ({relative:.1e}) |")
    return "\n".join(lines)


def moving_average(values: np.ndarray, dt: float) -> np.ndarray | None:
    """The mean over SMOOTHING seconds around each sample (the ends are cut off); None when
    the span is shorter than two windows."""
    window = max(1, int(round(SMOOTHING / dt)))
    if 2 * window > len(values):
        return None
    return np.convolve(values, np.ones(window) / window, mode="valid")


def convergence_table(runs: list[Run]) -> str:
    """Values at the end of the span and, for each mesh, the largest difference to the next
    coarser one over the span: raw, and of the moving averages over SMOOTHING."""
    lines = ["| elements/link | chord2(t_end) rad | max diff | smoothed | tip2(t_end) m "
             "| max diff | smoothed |", "|---|---|---|---|---|---|---|"]
    dt = runs[0].result.dt_out
    for k, run in enumerate(runs):
        cells = [str(run.elements)]
        for name in OUTPUTS:
            values = run.result.output(name)
            cells.append(f"{values[-1]:.8f}" if name == "chord2" else f"{values[-1]:.6e}")
            if k == 0:
                cells += ["", ""]
                continue
            coarse = runs[k - 1].result.output(name)
            fine_mean, coarse_mean = moving_average(values, dt), moving_average(coarse, dt)
            smoothed = ("span too short" if fine_mean is None else
                        f"{np.max(np.abs(fine_mean - coarse_mean)):.2e}")
            cells += [f"{np.max(np.abs(values - coarse)):.2e}", smoothed]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def low_passed(values: np.ndarray, dt: float) -> np.ndarray:
    """values through a zero-phase 4th-order Butterworth low-pass at LOW_PASS Hz, its start and
    end states chosen by Gustafsson's method (scipy's filtfilt method="gust"). filtfilt's
    default pads with 15 samples of odd extension, too few for the filter's transient: the
    bending waves at the record's end then leaked into the band, and the last 20 ms of two
    runs differed by up to ten times what the rest did (two_link_flex at 16 elements against
    64: 1.2e-5 m there, 1.0e-6 m elsewhere)."""
    b, a = signal.butter(4, LOW_PASS, fs=1.0 / dt)
    return signal.filtfilt(b, a, values, method="gust")


def reference_table(runs: list[Run]) -> str:
    """Each run against the references of bench/beam_reference.py (same mesh, explicit step,
    every mode resolved; and the finest one there is, the mesh-converged one), on their
    common output times: the largest difference of chord2, of tip2 raw and of tip2
    low-passed at LOW_PASS Hz (sampled at the common times: write the references with the
    runs' dt_out, or content above their Nyquist frequency folds into the band)."""
    found = {n: np.load(reference_path(n)) for n in (2, 4, 8, 16, 32, 64)
             if reference_path(n).exists()}
    if not found:
        return ("no reference: run bench/beam_reference.py --elements 16 (about 4 minutes) "
                "to write one")
    finest = max(found)
    lines = [f"| elements/link | reference | chord2 rad | tip2 m | tip2 low-passed {LOW_PASS:g} "
             "Hz m |", "|---|---|---|---|---|"]
    for run in runs:
        for n in sorted({run.elements, finest} & set(found)):
            ref = found[n]
            times = run.result.times
            k = np.searchsorted(ref["times"], times - 1e-12)
            ok = (k < len(ref["times"])) & (np.abs(ref["times"][np.minimum(k, len(ref["times"]) - 1)] - times) < 1e-9)
            if ok.sum() < 10:
                continue
            k = k[ok]
            chord = np.abs(run.result.output("chord2")[ok] - ref["chord2"][k]).max()
            tip, tip_ref = run.result.output("tip2")[ok], ref["tip2"][k]
            dt = float(times[ok][1] - times[ok][0])  # the common times' spacing
            smooth = np.abs(low_passed(tip, dt) - low_passed(tip_ref, dt)).max()
            label = f"{n} elements, {ref['solver']} tol {float(ref['tol']):g}"
            lines.append(f"| {run.elements} | {label} | {chord:.1e} | "
                         f"{np.abs(tip - tip_ref).max():.1e} | {smooth:.1e} |")
    return "\n".join(lines)


def cantilever_frequency(elements: int, out_dir: Path) -> str:
    """The run-based first bending frequency of a clamped beam with `elements` elements."""
    path = out_dir / "cantilever.dep"
    path.write_text(CANTILEVER.format(n=elements), encoding="utf-8")
    sim = depsim.load(path).compile(target="numpy", out_dir=out_dir / "cantilever")
    start = time.perf_counter()
    result = sim.run()
    seconds = time.perf_counter() - start
    t, y = result.times, result.output("deflection")

    def misfit(omegas):  # y = c + sum a cos(w t) + b sin(w t); amplitudes by linear lstsq
        basis = np.column_stack([np.ones_like(t)] + [f(w * t) for w in omegas
                                                     for f in (np.cos, np.sin)])
        return basis @ np.linalg.lstsq(basis, y, rcond=None)[0] - y

    exact = CANTILEVER_ROOTS[0] ** 2 * np.sqrt(100.0)
    ratio = (CANTILEVER_ROOTS[1] / CANTILEVER_ROOTS[0]) ** 2
    omega = optimize.least_squares(misfit, [exact, exact * ratio], x_scale=[1, ratio]).x[0]
    return (f"cantilever, {elements} elements, 0.45 s: omega_1 = {omega:.5f} rad/s, beam theory "
            f"{exact:.5f}, error {omega / exact - 1:+.1e}; {seconds:.0f} s wall, "
            f"{result.stats.accepted_steps} steps")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--span", type=float, default=0.1, help="simulated time (s)")
    parser.add_argument("--elements", default="2,4,8,16", help="element counts per link")
    parser.add_argument("--tol", type=float, default=1e-8, help="integration tolerance")
    parser.add_argument("--dt-out", type=float, default=5e-4,
                        help="output interval (s); fine enough that the bending waves do not "
                             "alias into the smoothed differences")
    parser.add_argument("--energy-span", type=float, default=None,
                        help="also run 2 elements over this span (s) for the energy drift")
    parser.add_argument("--cantilever", type=int, default=8, metavar="N",
                        help="elements of the cantilever frequency run (0: skip)")
    parser.add_argument("--target", choices=["numpy", "c"], default="numpy",
                        help="backend (c: the compiled library, about 60x faster)")
    parser.add_argument("--stepping", choices=["auto", "explicit", "implicit"], default="auto",
                        help="the ODE method (docs/method.md, 10)")
    parser.add_argument("--explicit-too", action="store_true",
                        help="also run each mesh with stepping explicit, side by side")
    parser.add_argument("--save", metavar="NPZ", help="write times, chord2, tip2 and the "
                        "total energy of each run to this .npz file")
    args = parser.parse_args()
    counts = [int(n) for n in args.elements.split(",")]
    dt_out = min(args.dt_out, args.span / 10)
    with tempfile.TemporaryDirectory() as tmp:
        runs, explicit = [], []
        for n in counts:
            runs.append(run_m2(n, args.span, args.tol, dt_out, Path(tmp), args.target,
                               args.stepping))
            print(f"  {n} elements/link: {runs[-1].run_seconds:.1f} s", flush=True)
            if args.explicit_too:
                explicit.append(run_m2(n, args.span, args.tol, dt_out, Path(tmp), args.target,
                                       "explicit"))
                print(f"  {n} elements/link, explicit: {explicit[-1].run_seconds:.1f} s",
                      flush=True)
        print(f"\nM2 over {args.span} s, tol {args.tol:g}, stepping {args.stepping}, outputs "
              f"every {dt_out:g} s\n")
        print(cost_table(runs))
        if explicit:
            print("\nthe same with stepping explicit (DOPRI 5(4) throughout)\n")
            print(cost_table(explicit))
            print("\n" + "\n".join(
                f"{a.elements} elements/link: explicit / {args.stepping} = "
                f"{b.run_seconds / a.run_seconds:.1f} in time, "
                f"{b.result.stats.accepted_steps / a.result.stats.accepted_steps:.1f} in steps"
                for a, b in zip(runs, explicit)))
        print()
        print(convergence_table(runs))
        print()
        print(reference_table(runs + explicit))
        if args.save:
            np.savez(args.save, **{f"{key}_{run.elements}": value for run in runs
                                   for key, value in (("t", run.result.times),
                                                      ("chord2", run.result.output("chord2")),
                                                      ("tip2", run.result.output("tip2")),
                                                      ("energy", run.result.total_energy()))})
        if args.energy_span:
            long = run_m2(2, args.energy_span, args.tol, 0.005, Path(tmp), args.target)
            drift, relative = long.energy_drift()
            print(f"\n2 elements/link over {args.energy_span} s: {long.run_seconds:.0f} s wall "
                  f"({long.seconds_per_second:.0f} s per simulated s), "
                  f"{long.result.stats.accepted_steps} steps; energy drift {drift:.2e} J "
                  f"= {relative:.2e} of the largest kinetic energy; chord2(t_end) = "
                  f"{long.result.output('chord2')[-1]:.6f} rad, tip2(t_end) = "
                  f"{long.result.output('tip2')[-1]:.4e} m")
        if args.cantilever:
            print("\n" + cantilever_frequency(args.cantilever, Path(tmp)))


if __name__ == "__main__":
    main()
