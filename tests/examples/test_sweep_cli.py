"""`depsim sweep` end to end: a small grid study, and bad specs as usage errors."""

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
                assert float(study[name].values[run]) == value, name
