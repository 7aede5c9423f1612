"""Parameter studies end to end on a tiny hand-made module and a stand-in `simulate`:
inline, local process pool and Dask agree bit for bit with single runs; failures, killed
workers, interruption and resume, NetCDF round trip, summary, plot, progress."""

from __future__ import annotations

import io
import math
import os
import types

import numpy as np
import pytest

from depsim.runtime.sweep import (CheckpointError, ModuleRef, Study, load_module, make_design,
                                  open_study, partial_path, plot_study, run_study, summarize,
                                  sweep)
from depsim.runtime.sweep.metrics import evaluate
from depsim.runtime.sweep.progress import ProgressBar

# A damped oscillator "generated module": just what the stand-in simulate below needs.
OSCILLATOR = '''
import numpy as np
MODEL_NAME = "oscillator"
SOURCE_FILE = "oscillator.dep"
SOURCE_SHA256 = "ab" * 32
DEPSIM_VERSION = "hand-made"
PARAMETERS = ("k", "c", "m", "x0", "latch")
PARAMETER_DEFAULTS = (4.0, 0.2, 1.0, 1.0, -0.5)
PARAMETER_UNITS = ("N/m", "N*s/m", "kg", "m", "m")
NP = 5
HINGES = ("h1",)
LATCHES = ("h1",)
OUTPUTS = ("x", "v")
OUTPUT_UNITS = ("m", "m/s")
T_END, TOL, DT_OUT = 3.0, 1e-8, 0.01
'''


class FakeResult:
    def __init__(self, times, outputs, events, stats):
        self.times, self.outputs, self.events, self.stats = times, outputs, events, stats


def fake_simulate(module, p, t_end=None, dt_out=None, tol=None, progress=False):
    """RK4 on m x'' + c x' + k x = 0; event h1.latch when x first falls below `latch`.
    Raises for a non-positive mass; kills its process (a crash) for k > 1e6."""
    k, c, m, x0, latch = (float(v) for v in p)
    if m <= 0:
        raise ValueError(f"mass must be positive, got {m}")
    if k > 1e6:
        os._exit(7)
    t_end = module.T_END if t_end is None else t_end
    h = module.DT_OUT if dt_out is None else dt_out
    n = int(round(t_end / h))
    f = lambda y: np.array([y[1], -(c * y[1] + k * y[0]) / m])  # noqa: E731
    y = np.array([x0, 0.0])
    ys, events = [y], []
    for i in range(n):
        k1 = f(y); k2 = f(y + h / 2 * k1); k3 = f(y + h / 2 * k2); k4 = f(y + h * k3)  # noqa
        new = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        if not events and y[0] > latch >= new[0]:
            events.append(types.SimpleNamespace(name="h1.latch",
                                                t=i * h + h * (y[0] - latch) / (y[0] - new[0])))
        y = new
        ys.append(y)
    ys = np.array(ys)
    return FakeResult(np.arange(n + 1) * h, {"x": ys[:, 0], "v": ys[:, 1]}, events,
                      {"steps": n, "rejected": 0, "iterations": 4 * n})


def peak_speed(result):
    return float(np.max(np.abs(result.outputs["v"])))


CALLS = []


def counting_simulate(module, p, **kwargs):
    CALLS.append(float(p[0]))
    return fake_simulate(module, p, **kwargs)


@pytest.fixture
def module_path(tmp_path):
    path = tmp_path / "oscillator.py"
    path.write_text(OSCILLATOR)
    return path


def design(module_path, runs=24, seed=5, extra=()):
    module = load_module(module_path)
    return make_design(module.PARAMETERS, module.PARAMETER_DEFAULTS, runs=runs, seed=seed,
                       samples=["k=uniform(2, 8)", "c=normal(0.2, 0.05)", *extra])


def study(module_path, d, **kwargs):
    return Study(module_path, d, t_end=2.0, metrics={"peak_speed": peak_speed},
                 simulate=fake_simulate, **kwargs)


def single_run_metrics(module_path, p):
    """What one plain simulate call gives: the reference for the sweep's numbers."""
    module = load_module(module_path)
    values, _ = evaluate(fake_simulate(module, p, t_end=2.0), module,
                         {"peak_speed": peak_speed})
    return values


def assert_same_as_single_runs(ds, module_path, d):
    assert not ds["failed"].any()
    for i in range(d.runs):
        expected = single_run_metrics(module_path, d.matrix[i])
        for name, value in expected.items():
            got = float(ds[name].values[i])
            assert got == value or (math.isnan(got) and math.isnan(value)), (i, name)


def without_timing(ds):
    return ds.drop_vars("wall_time")


def test_inline_matches_single_runs_and_records_everything(module_path, tmp_path):
    d = design(module_path, runs=12)
    ds = run_study(study(module_path, d, time_grid=5), scheduler="inline",
                   store=tmp_path / "s.nc")
    assert_same_as_single_runs(ds, module_path, d)
    assert list(ds.data_vars)[:3] == ["deployed", "time_to_deploy", "event.h1.latch.t"]
    latched = ds["deployed"].values == 1
    assert latched.any() and np.array_equal(ds["time_to_deploy"].values[latched],
                                            ds["event.h1.latch.t"].values[latched])
    assert np.isnan(ds["time_to_deploy"].values[~latched]).all()
    # every metric and parameter carries its unit (OSCILLATOR's PARAMETER_UNITS, OUTPUT_UNITS)
    units = {name: ds[name].attrs.get("units") for name in ds.data_vars}
    assert units["final.x"] == "m" and units["final.v"] == "m/s"
    assert units["event.h1.latch.t"] == units["time_to_deploy"] == "s"
    assert units["deployed"] == units["stats.steps"] == "1" and units["peak_speed"] is None
    assert ds["k"].attrs["units"] == "N/m" and ds["c"].attrs["units"] == "N*s/m"
    assert ds["parameter_unit"].values.tolist() == ["N/m", "N*s/m", "kg", "m", "m"]
    for name in ("final.x", "final.v", "stats.steps", "stats.rejected", "stats.iterations",
                 "peak_speed", "wall_time", "output.x", "output.v"):
        assert name in ds
    assert ds["output.x"].dims == ("run", "time") and ds["output.x"].shape == (12, 5)
    assert np.array_equal(ds["k"].values, d.values("k"))  # parameters are coordinates
    assert np.array_equal(ds["parameter_values"].values, d.matrix)
    assert ds.attrs["seed"] == 5 and ds.attrs["model"] == "oscillator"
    assert ds.attrs["source_sha256"] == "ab" * 32 and "uniform(2.0, 8.0)" in ds.attrs["spec"]
    assert ds.attrs["depsim_version"] and ds.attrs["runs"] == 12
    assert (ds["wall_time"] > 0).all()
    # NetCDF round trip: the file holds exactly the returned dataset
    back = open_study(tmp_path / "s.nc")
    import xarray as xr
    xr.testing.assert_identical(back, ds)
    for name in ds.variables:
        assert back[name].dtype == ds[name].dtype, name
        assert np.array_equal(back[name].values, ds[name].values, equal_nan=
                              back[name].dtype.kind == "f"), name
    assert not partial_path(tmp_path / "s.nc").exists()


def blas_threads(result):
    return float(os.environ.get("OPENBLAS_NUM_THREADS", "nan"))


def test_local_pool_matches_single_runs_bit_for_bit(module_path, monkeypatch):
    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    d = design(module_path, runs=40)
    s = Study(module_path, d, t_end=2.0, simulate=fake_simulate,
              metrics={"peak_speed": peak_speed, "blas_threads": blas_threads})
    ds = run_study(s, workers=2, batch_size=7)
    assert_same_as_single_runs(ds, module_path, d)
    assert (ds["blas_threads"] == 1).all()  # one BLAS thread per worker process
    assert "OPENBLAS_NUM_THREADS" not in os.environ  # and the parent's environment is back
    inline = run_study(s, scheduler="inline")
    import xarray as xr
    xr.testing.assert_identical(without_timing(ds).drop_vars("blas_threads"),
                                without_timing(inline).drop_vars("blas_threads"))


def test_failing_runs_are_recorded_and_the_study_goes_on(module_path, tmp_path):
    d = design(module_path, runs=10, extra=["m=normal(0.3, 0.5)"])
    masses = d.values("m")
    assert (masses <= 0).any() and (masses > 0).any()
    run_study(study(module_path, d), scheduler="inline", store=tmp_path / "f.nc")
    ds = open_study(tmp_path / "f.nc")  # what the file says
    bad = masses <= 0
    assert ds["failed"].values.tolist() == bad.tolist()
    for i in np.flatnonzero(bad):
        assert ds["error"].values[i] == f"ValueError: mass must be positive, got {masses[i]}"
        assert np.isnan(ds["final.x"].values[i]) and np.isnan(ds["peak_speed"].values[i])
        assert np.isnan(ds["deployed"].values[i])
    assert np.isfinite(ds["final.x"].values[~bad]).all()
    text = summarize(ds)
    assert f"{bad.sum()} failed" in text and "mass must be positive" in text


def test_a_module_the_runtime_cannot_run_fails_each_run_not_the_study(module_path):
    """Without metrics of its own a study reads each run's end (RunEnds); a module the
    integrator core cannot bind (OSCILLATOR has no model functions) fails every run with the
    reason, as a plain simulate does, and the study completes."""
    d = design(module_path, runs=3)
    ds = run_study(Study(module_path, d, t_end=2.0), scheduler="inline")
    assert ds["failed"].all()
    assert all(error.startswith("TypeError: ") for error in ds["error"].values)


def test_a_run_that_kills_its_worker_is_recorded_as_failed(module_path):
    d = design(module_path, runs=12)
    matrix = d.matrix.copy()
    matrix[5, 0] = 2e6  # fake_simulate exits the process for k > 1e6
    import dataclasses
    d = dataclasses.replace(d, matrix=matrix)
    ds = run_study(study(module_path, d), workers=2, batch_size=4)
    assert ds["failed"].values.tolist() == [i == 5 for i in range(12)]
    assert "worker process died" in ds["error"].values[5]
    ok = [i for i in range(12) if i != 5]
    for i in ok:
        assert ds["final.x"].values[i] == single_run_metrics(module_path, matrix[i])["final.x"]


def test_interrupted_study_resumes_to_the_identical_result(module_path, tmp_path):
    d = design(module_path, runs=30)
    store = tmp_path / "study.nc"

    def interrupt_after_10(progress):
        if progress.done >= 10:
            raise KeyboardInterrupt

    CALLS.clear()
    s = Study(module_path, d, t_end=2.0, metrics={"peak_speed": peak_speed},
              simulate=counting_simulate)
    with pytest.raises(KeyboardInterrupt):
        run_study(s, scheduler="inline", store=store, batch_size=5, on_batch=interrupt_after_10)
    assert not store.exists()
    lines = partial_path(store).read_text().splitlines()
    assert len(lines) == 1 + 10  # header + the 10 finished runs
    with open(partial_path(store), "a") as f:
        f.write('{"run": 11, "failed": fal')  # a torn last line (killed mid-write)
    CALLS.clear()
    resumed = run_study(s, scheduler="inline", store=store, resume=True, batch_size=5)
    assert len(CALLS) == 20  # only the rest ran
    assert not partial_path(store).exists()
    whole = run_study(s, scheduler="inline", store=tmp_path / "whole.nc")
    import xarray as xr
    xr.testing.assert_identical(without_timing(resumed), without_timing(whole))
    a, b = open_study(store), open_study(tmp_path / "whole.nc")
    xr.testing.assert_identical(without_timing(a).drop_attrs(), without_timing(b).drop_attrs())
    assert a.attrs == b.attrs
    # resuming a finished study does nothing
    CALLS.clear()
    again = run_study(s, scheduler="inline", store=store, resume=True)
    assert CALLS == [] and again.sizes["run"] == 30


def test_interrupted_pool_study_resumes(module_path, tmp_path):
    d = design(module_path, runs=40)
    store = tmp_path / "study.nc"

    def interrupt(progress):
        if progress.done >= 8:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_study(study(module_path, d), workers=2, store=store, batch_size=4,
                  on_batch=interrupt)
    kept = len(partial_path(store).read_text().splitlines()) - 1
    assert 8 <= kept < 40
    resumed = run_study(study(module_path, d), workers=2, store=store, resume=True,
                        batch_size=4)
    assert_same_as_single_runs(resumed, module_path, d)


def test_resume_refuses_a_checkpoint_of_another_study(module_path, tmp_path):
    store = tmp_path / "s.nc"
    partial_path(store).write_text('{"depsim_sweep_partial": 1, "fingerprint": "x", '
                                   '"runs": 3}\n')
    with pytest.raises(CheckpointError, match="belongs to a different study"):
        run_study(study(module_path, design(module_path, runs=3)), scheduler="inline",
                  store=store, resume=True)


def test_resume_finds_a_random_seed_in_the_checkpoint(module_path, tmp_path):
    store = tmp_path / "s.nc"
    args = dict(samples=["k=uniform(2, 8)"], runs=6, simulate=fake_simulate, t_end=1.0,
                scheduler="inline", out=store, batch_size=2)

    def interrupt(progress):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        sweep(module_path, on_batch=interrupt, **args)
    ds = sweep(module_path, resume=True, **args)  # no seed given: the stored one is used
    fresh = sweep(module_path, seed=int(ds.attrs["seed"]), **{**args, "out": None})
    assert np.array_equal(ds["k"].values, fresh["k"].values)


def test_module_sent_as_source_loads_where_the_path_is_missing(module_path, tmp_path,
                                                               monkeypatch):
    monkeypatch.setenv("DEPSIM_CACHE", str(tmp_path / "cache"))
    ref = ModuleRef.from_path(module_path, include_source=True)
    moved = ModuleRef(str(tmp_path / "elsewhere" / "oscillator.py"), ref.sha256, ref.source)
    from depsim.runtime.sweep import worker
    worker._MODULES.pop(ref.sha256, None)
    module = load_module(moved)
    assert module.MODEL_NAME == "oscillator"
    assert (tmp_path / "cache" / "sweep-modules").is_dir()
    with pytest.raises(FileNotFoundError, match="not on this machine"):
        worker._MODULES.clear()
        load_module(ModuleRef(str(tmp_path / "nowhere.py"), ref.sha256))


def test_summary_and_plot(module_path, tmp_path):
    d = design(module_path, runs=60)
    ds = run_study(study(module_path, d), scheduler="inline")
    text = summarize(ds)
    assert "60 runs, 0 failed, seed 5" in text
    line = next(l for l in text.splitlines() if l.startswith("event.h1.latch.t"))
    assert line.split()[-2] == "k" or "k " in line  # stiffness drives the latch time
    k_rho = dict((p, r) for p, r in __import__("depsim.runtime.sweep", fromlist=["drivers"])
                 .drivers(ds, "event.h1.latch.t"))["k"]
    assert k_rho < -0.9
    assert "deployed" in text and "P(not deployed)" in text
    png = plot_study(ds, tmp_path / "study.png")
    data = png.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000


def test_rank_correlation_matches_scipy_with_ties_and_missing_values():
    from scipy.stats import rankdata, spearmanr

    from depsim.runtime.sweep.summary import ranks, spearman

    rng = np.random.default_rng(3)
    x = rng.normal(size=500)
    y = np.round(2 * x + rng.normal(size=500), 1)  # many ties
    y[[3, 40, 77]] = np.nan
    x[[5, 99]] = np.inf
    assert np.array_equal(ranks(y[np.isfinite(y)]), rankdata(y[np.isfinite(y)]))
    keep = np.isfinite(x) & np.isfinite(y)
    expected = spearmanr(x[keep], y[keep]).statistic
    assert spearman(x, y) == pytest.approx(expected, rel=1e-12)
    # ranks computed once serve every pairing where all pairs are finite
    z = rng.permutation(np.repeat(np.arange(50.0), 10))
    assert spearman(z, -z, ranks(z), ranks(-z)) == pytest.approx(-1.0, rel=1e-14)
    w = z + rng.normal(size=z.size)
    assert spearman(z, w, ranks(z), ranks(w)) == pytest.approx(spearmanr(z, w).statistic,
                                                               rel=1e-12)
    assert spearman(x, y, ranks(x)) == pytest.approx(expected, rel=1e-12)  # not all finite
    assert math.isnan(spearman(np.ones(9), np.arange(9.0)))
    assert math.isnan(spearman(np.arange(2.0), np.arange(2.0)))


def test_progress_bar_only_on_a_terminal():
    quiet = io.StringIO()
    bar = ProgressBar(10, stream=quiet)
    bar.update(5, 1, force=True)
    bar.close()
    assert quiet.getvalue() == ""
    loud = io.StringIO()
    bar = ProgressBar(10, stream=loud, enabled=True)
    bar.update(5, 1, force=True)
    bar.close()
    assert "5/10 runs, 1 failed" in loud.getvalue() and "ETA" in loud.getvalue()


@pytest.fixture(scope="module")
def dask_client():
    import distributed
    import logging
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=None, silence_logs=logging.ERROR)
    client = distributed.Client(cluster)
    yield client
    client.close()
    cluster.close()


def test_dask_matches_single_runs_bit_for_bit(module_path, dask_client, tmp_path):
    d = design(module_path, runs=30)
    ds = run_study(study(module_path, d), scheduler=dask_client, batch_size=6,
                   store=tmp_path / "d.nc")
    assert_same_as_single_runs(ds, module_path, d)
    inline = run_study(study(module_path, d), scheduler="inline")
    import xarray as xr
    xr.testing.assert_identical(without_timing(ds), without_timing(inline))


def test_dask_worker_without_the_file_gets_the_source(module_path, dask_client, tmp_path):
    """A remote worker cannot see the submitting machine's file: it imports the bytes sent
    with the study from its own cache, keyed by their hash."""
    from depsim.runtime.sweep import backends
    from depsim.runtime.sweep.worker import RunConfig

    d = design(module_path, runs=4)
    ref = ModuleRef.from_path(module_path, include_source=True)
    remote = ModuleRef(str(tmp_path / "not-on-workers" / "oscillator.py"), ref.sha256,
                       ref.source)

    def forget():
        from depsim.runtime.sweep import worker
        worker._MODULES.clear()

    dask_client.run(forget)
    config = RunConfig(t_end=2.0, metrics={"peak_speed": peak_speed}, simulate=fake_simulate)
    batches = list(backends.run_dask(remote, config, d.matrix, [[0, 1], [2, 3]], dask_client))
    records = sorted((r for b in batches for r in b), key=lambda r: r["run"])
    assert [r["failed"] for r in records] == [False] * 4
    assert [r["values"]["final.x"] for r in records] == \
        [single_run_metrics(module_path, p)["final.x"] for p in d.matrix]


# --- the real integrator ---------------------------------------------------------------------

HAND_MADE_PENDULUM = os.path.join(os.path.dirname(__file__), "models", "pendulum.py")


def real_simulate():
    import depsim.runtime as runtime
    return runtime.simulate


def compiled_pendulum(tmp_path_factory):
    """examples/pendulum.dep through the real front end and code generator."""
    from depsim.codegen import compile_numpy
    from depsim.dsl import load_model
    root = os.path.dirname(os.path.dirname(os.path.dirname(__file__)))
    model = load_model(os.path.join(root, "examples", "pendulum.dep"))
    return compile_numpy(model, tmp_path_factory.mktemp("pendulum"))


def assert_real_sweep_matches(ds, path, d, t_end):
    simulate = real_simulate()
    module = load_module(path)
    failed = ds["failed"].values
    for i in range(d.runs):
        try:
            result = simulate(module, d.matrix[i], t_end=t_end)
        except Exception as exc:
            assert failed[i] and str(exc) in ds["error"].values[i]
            continue
        assert not failed[i]
        expected, _ = evaluate(result, module, None)
        for name in module.OUTPUTS:  # the outputs themselves, bit for bit
            assert ds[f"final.{name}"].values[i] == result.output(name)[-1]
        for name, value in expected.items():
            got = ds[name].values[i]
            assert got == value or (math.isnan(got) and math.isnan(value)), (i, name)


@pytest.mark.parametrize("where", ["pool", "dask"])
def test_real_simulate_hand_made_pendulum(where, request, tmp_path):
    real_simulate()
    module = load_module(HAND_MADE_PENDULUM)
    d = make_design(module.PARAMETERS, module.PARAMETER_DEFAULTS, runs=6, seed=11,
                    samples=["L=uniform(0.5, 1.5)", "m=normal(1.0, 1.0)", "c=uniform(0, 0.3)"])
    assert (d.values("m") <= 0).any()  # some runs must fail: non-positive mass
    s = Study(HAND_MADE_PENDULUM, d, t_end=0.3)
    if where == "pool":
        ds = run_study(s, workers=2, batch_size=2, store=tmp_path / "p.nc")
    else:
        ds = run_study(s, scheduler=request.getfixturevalue("dask_client"), batch_size=2)
    assert ds["failed"].values.tolist() == (d.values("m") <= 0).tolist()
    assert "SolverError" in ds["error"].values[np.flatnonzero(d.values("m") <= 0)[0]]
    assert "stats.accepted_steps" in ds and "stats.position.total" in ds
    assert_real_sweep_matches(ds, HAND_MADE_PENDULUM, d, 0.3)


@pytest.mark.parametrize("where", ["pool", "dask"])
def test_real_compiled_pendulum_example(where, request, tmp_path_factory):
    real_simulate()
    path = compiled_pendulum(tmp_path_factory)
    module = load_module(path)
    grid = [f"{module.PARAMETERS[0]}={module.PARAMETER_DEFAULTS[0] * 0.8!r}:"
            f"{module.PARAMETER_DEFAULTS[0] * 1.2!r}:4"]
    d = make_design(module.PARAMETERS, module.PARAMETER_DEFAULTS, grid=grid)
    s = Study(path, d, t_end=0.2, time_grid=3)
    scheduler = request.getfixturevalue("dask_client") if where == "dask" else None
    ds = run_study(s, scheduler=scheduler, workers=2, batch_size=1)
    assert not ds["failed"].any()
    assert_real_sweep_matches(ds, path, d, 0.2)


def test_dask_by_address_and_an_unreachable_scheduler(module_path, dask_client, monkeypatch):
    from depsim.runtime.sweep import StudyError, backends

    d = design(module_path, runs=4)
    ds = run_study(study(module_path, d), scheduler=dask_client.scheduler.address)
    assert_same_as_single_runs(ds, module_path, d)
    monkeypatch.setattr(backends, "CONNECT_TIMEOUT", "1s")
    with pytest.raises(StudyError, match="cannot reach the Dask scheduler at tcp://127.0.0.1:9"):
        run_study(study(module_path, d), scheduler="tcp://127.0.0.1:9")


def positive_mass(p):
    return [] if p[2] > 0 else [f"m must be positive, got {p[2]:g} kg"]


def test_runs_the_check_refuses_are_failed_unrun_and_stay_so_on_resume(module_path, tmp_path):
    d = design(module_path, runs=12, extra=["m=normal(0.3, 0.5)"])
    bad = d.values("m") <= 0
    assert bad.any() and not bad.all()
    store = tmp_path / "s.nc"
    s = Study(module_path, d, t_end=2.0, simulate=counting_simulate, check=positive_mass)

    def interrupt(progress):
        raise KeyboardInterrupt

    CALLS.clear()
    with pytest.raises(KeyboardInterrupt):
        run_study(s, scheduler="inline", store=store, batch_size=2, on_batch=interrupt)
    CALLS.clear()
    ds = run_study(s, scheduler="inline", store=store, resume=True, batch_size=2)
    assert ds["failed"].values.tolist() == bad.tolist()
    for i in np.flatnonzero(bad):
        assert ds["error"].values[i] == \
            f"out of the model's ranges: m must be positive, got {d.values('m')[i]:g} kg"
        assert np.isnan(ds["final.x"].values[i]) and np.isnan(ds["wall_time"].values[i])
    assert sorted(CALLS) == sorted(d.values("k")[~bad][2:].tolist())  # the rest ran, once


NO_GUARD_SCRIPT = '''
import json, sys, types
import numpy as np
from depsim.runtime.sweep import sweep

with open("ran.txt", "a") as f:   # once per run of this script
    f.write("ran\\n")


def line(module, p, t_end=None, dt_out=None, tol=None, progress=False):
    t = np.linspace(0.0, 1.0, 5)
    return types.SimpleNamespace(times=t, outputs={"x": p[0] * t, "v": p[0] + 0 * t},
                                 events=[], stats={"steps": 4})


def twice_k(result):
    return 2 * float(result.outputs["v"][0])


study = sweep(sys.argv[1], samples=["k=uniform(2, 8)"], runs=6, seed=1, workers=2,
              batch_size=1, simulate=line, metrics={"twice_k": twice_k})
print(json.dumps({"failed": study["failed"].values.tolist(),
                  "twice_k": study["twice_k"].values.tolist(),
                  "k": study["k"].values.tolist()}))
'''


def test_a_script_without_a_main_guard_runs_a_pool_study_once(module_path, tmp_path):
    """Spawned workers import the main script again, unless told not to: a study started
    from a script without `if __name__ == "__main__":` must work, its functions defined
    there reach the workers, and the script runs once, not once per worker."""
    import json
    import subprocess
    import sys

    script = tmp_path / "study.py"
    script.write_text(NO_GUARD_SCRIPT)
    done = subprocess.run([sys.executable, str(script), str(module_path)], cwd=tmp_path,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    got = json.loads(done.stdout.strip().splitlines()[-1])
    assert got["failed"] == [False] * 6
    assert got["twice_k"] == [2 * k for k in got["k"]]
    assert (tmp_path / "ran.txt").read_text() == "ran\n"
