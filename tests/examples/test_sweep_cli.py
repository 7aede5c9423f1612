"""`depsim sweep` end to end: a small grid study, and bad specs as usage errors."""

import math

import numpy as np
import xarray as xr

from e2e import EXAMPLES


def test_grid_study_writes_netcdf_and_summary(cli, tmp_path):
    out, plot = tmp_path / "study.nc", tmp_path / "study.png"
    done = cli("sweep", EXAMPLES / "pendulum.dep", "--grid", "L=0.5m:1.5m:3", "--t-end", "0.5",
               "--workers", "1", "-o", out, "--plot", plot)
    assert done.returncode == 0, done.stderr
    with xr.open_dataset(out, engine="h5netcdf") as study:
        assert study.sizes["run"] == 3
        assert list(study["L"].values) == [0.5, 1.0, 1.5]
    assert "theta" in done.stdout
    assert plot.read_bytes()[:4] == b"\x89PNG"


def test_bad_specs_are_usage_errors(cli, tmp_path):
    done = cli("sweep", EXAMPLES / "pendulum.dep", "--grid", "L=1:2", "-o", tmp_path / "x.nc")
    assert done.returncode == 2 and "L=1:2" in done.stderr
    done = cli("sweep", EXAMPLES / "pendulum.dep", "--sample", "m=gauss(1,2)", "--runs", "3",
               "-o", tmp_path / "y.nc")
    assert done.returncode == 2 and "gauss" in done.stderr
    done = cli("sweep", EXAMPLES / "pendulum.dep", "--grid", "nosuch=1:2:3",
               "-o", tmp_path / "z.nc")
    assert done.returncode == 2 and "nosuch" in done.stderr
    assert "Traceback" not in done.stderr
    assert list(tmp_path.iterdir()) == []


def test_default_study_measures_what_single_runs_do(cli, tmp_path):
    """Without metrics of its own, a time grid or a dt_out, a study asks each run for its end
    alone (runtime/sweep/study.py): its built-in metrics (events, peak loads, final outputs,
    step counts) must be those of plain runs at the model's own output interval."""
    import depsim
    from depsim.runtime.sweep.metrics import evaluate

    out = tmp_path / "study.nc"
    done = cli("sweep", EXAMPLES / "pendulum.dep", "--grid", "L=0.5m:1.5m:2", "--t-end", "0.5",
               "--workers", "1", "-o", out)
    assert done.returncode == 0, done.stderr
    sim = depsim.load(EXAMPLES / "pendulum.dep").compile("c")
    with xr.open_dataset(out, engine="h5netcdf") as study:
        for run, length in enumerate((0.5, 1.5)):
            result = sim.run(set={"L": length}, t_end=0.5)
            assert len(result.times) > 2  # the model's dt_out: many rows
            expected, _ = evaluate(result, sim.module, None, True)
            for name, value in expected.items():
                if name.startswith("stats.") and "wall" in name:
                    continue
                got = float(study[name].values[run])
                if name.startswith("peak.") and ".t_" not in name:
                    # the plain run's peak also sees its output times between the steps;
                    # the load varies by O(h^2) of its size there (h: 1e-2 s steps)
                    assert value * (1 - 1e-3) <= got <= value, name
                    continue
                if name.startswith("peak.") and ".t_" in name:
                    continue  # the instant of that peak: a step's or an output time's
                assert got == value or (math.isnan(got) and math.isnan(value)), name


def test_values_out_of_the_models_ranges_are_failed_runs_with_their_reason(cli, tmp_path):
    """A grid reaching a negative friction or length: those runs are failed, with the range
    they break (the checks `--set` applies), and are not run; the others are."""
    out = tmp_path / "study.nc"
    done = cli("sweep", EXAMPLES / "intelsat5.dep", "--grid", "h2.friction=-0.7:0.7:3",
               "--grid", "panel1.length=-1.965:1.965:2", "--t-end", "2", "--workers", "1",
               "-o", out)
    assert done.returncode == 0, done.stderr
    assert "6 runs, 4 failed" in done.stdout and "failed runs: 4 of 6" in done.stdout
    friction = "h2.friction must not be negative, got -0.7 N*m"
    length = "panel1.length must be positive, got -1.965 m"
    with xr.open_dataset(out, engine="h5netcdf") as study:
        assert study["failed"].values.tolist() == [True, True, True, False, True, False]
        errors = [str(e) for e in study["error"].values]
        assert errors[0] == f"out of the model's ranges: {length}; {friction}"
        assert errors[1] == f"out of the model's ranges: {friction}"
        assert errors[2] == errors[4] == f"out of the model's ranges: {length}"
        assert np.isnan(study["wall_time"].values[[0, 1, 2, 4]]).all()  # never run
        assert np.isfinite(study["final.theta1"].values[[3, 5]]).all()
    done = cli("run", EXAMPLES / "intelsat5.dep", "--set", "h2.friction=-0.7", "--t-end", "2")
    assert done.returncode == 2 and friction in done.stderr  # the same check as --set


def test_the_core_refuses_the_runs_the_study_refuses_in_the_same_words():
    """The runs a study records as out of the model's ranges (depsim.dsl.check_parameters)
    are those the integrator core refuses, with the same message: run with the parameter
    vector the study recorded, and in a study without the Python check, where the core's
    refusal is the run's failure."""
    import depsim
    import pytest

    from depsim.runtime import simulate
    from depsim.runtime.sweep import sweep as run_sweep

    sim = depsim.load(EXAMPLES / "pendulum.dep").compile("c")
    grid = ["L=-1:1:3", "pivot.slip_rate=-0.01:0.01:2"]
    checked = depsim.sweep(sim, grid=grid, t_end=0.2, scheduler="inline", progress=False)
    unchecked = run_sweep(sim.module.__file__, grid=grid, t_end=0.2, scheduler="inline",
                          progress=False)
    failed = checked["failed"].values
    assert failed.tolist() == [True, True, True, True, True, False]
    assert unchecked["failed"].values.tolist() == failed.tolist()
    prefix = "out of the model's ranges: "
    for run in np.flatnonzero(failed):
        recorded = str(checked["error"].values[run])
        assert recorded.startswith(prefix)
        with pytest.raises(ValueError) as caught:
            simulate(sim.module, checked["parameter_values"].values[run], t_end=0.2)
        assert str(caught.value) == recorded.removeprefix(prefix)
        assert str(unchecked["error"].values[run]) == f"ValueError: {caught.value}"


def test_a_limit_gives_the_probability_of_exceeding_it(cli, tmp_path):
    out = tmp_path / "study.nc"
    done = cli("sweep", EXAMPLES / "pendulum.dep", "--grid", "m=1kg:3kg:3", "--t-end", "0.5",
               "--workers", "1", "--limit", "peak.pivot.force=40 N", "-o", out)
    assert done.returncode == 0, done.stderr
    with xr.open_dataset(out, engine="h5netcdf") as study:
        above = int((study["peak.pivot.force"].values > 40).sum())
    assert 0 < above < 3  # the heavier bars pull harder on the pivot
    assert f"P(peak.pivot.force > 40 N) = {100 * above / 3:.1f} % (95 % CI " in done.stdout
    assert f"Clopper-Pearson; {above} of 3 runs)" in done.stdout
    for limit, message in [("peak.pivot.force=40 m", "peak.pivot.force is in N; '40 m' has "
                                                     "another dimension"),
                           ("peak.nosuch.force=1", "no metric 'peak.nosuch.force'"),
                           ("peak.pivot.force", "expected METRIC=VALUE")]:
        done = cli("sweep", EXAMPLES / "pendulum.dep", "--grid", "m=1kg:3kg:3", "--limit",
                   limit, "-o", tmp_path / "x.nc")
        assert done.returncode == 2 and message in done.stderr, done.stderr
        assert not (tmp_path / "x.nc").exists() and "Traceback" not in done.stderr


def test_local_study_prints_the_first_order_table(cli, tmp_path):
    """sweep --local: one run with sensitivities at the samples' means; the derivatives are
    the run's (tests/runtime/test_local_study.py checks them against a Monte Carlo)."""
    done = cli("sweep", EXAMPLES / "intelsat5.dep", "--sample", "h1.friction=normal(0.68,0.068)",
               "--sample", "h1.preload=normal(1.7 N*m, 0.17 N*m)", "--local", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "h1.preload = 1.7 +- 0.17 (1 sigma)" in done.stdout
    assert "time_to_deploy" in done.stdout and "d/d h1.friction" in done.stdout
    assert list(tmp_path.iterdir()) == []  # nothing written
    done = cli("sweep", EXAMPLES / "intelsat5.dep", "--sample", "h1.friction=normal(1,0.1)",
               "--runs", "10", "--local")
    assert done.returncode == 2 and "--runs" in done.stderr
    done = cli("sweep", EXAMPLES / "free_flyer.dep", "--sample", "h1.friction=normal(1,0.1)",
               "--local")
    assert done.returncode == 2 and "spring kick" in done.stderr
    assert "Traceback" not in done.stderr
