"""Result export (CSV, JSON, PNG), output grid, defaults and the progress bar."""

import csv
import io
import json
import os

import numpy as np
import pytest
from runtime_helpers import variant

import depsim.runtime.progress as progress_module
from depsim.runtime import Event, simulate
from depsim.runtime.plot import plot_outputs


@pytest.fixture(scope="module")
def result(pendulum):
    swing = Event("bottom", lambda t, q, qd: q[2] + np.pi / 2, direction=-1)
    return simulate(pendulum, t_end=0.7, dt_out=0.05, tol=1e-8, events=[swing])


def test_csv_round_trip_is_exact(result, tmp_path):
    path = tmp_path / "out.csv"
    result.to_csv(path)
    with open(path, newline="") as handle:
        rows = list(csv.reader(handle))
    assert rows[0] == ["t", "theta", "omega", "tip_x", "tip_y"]
    table = np.array(rows[1:], dtype=float)
    assert np.array_equal(table[:, 0], result.times)  # %.17g round-trips doubles exactly
    assert np.array_equal(table[:, 1:], result.outputs)


def test_json_summary_round_trip(result, tmp_path):
    path = tmp_path / "summary.json"
    result.to_json(path)
    data = json.loads(path.read_text())
    assert data["model"] == "pendulum" and data["method"] == "iterative"
    assert data["parameters"] == dict(zip(result.parameter_names, result.parameters.tolist()))
    assert data["tolerances"]["tol"] == 1e-8
    assert data["tolerances"]["constraint_tol"] == result.constraint_tol
    stats = data["statistics"]
    assert stats["accepted_steps"] == result.stats.accepted_steps > 0
    assert set(stats["position"]) == {"mean", "max", "total"}
    assert stats["max_v_pos"] == result.stats.max_v_pos
    assert data["events"] == [{"name": "bottom", "t": result.events[0].t}]


def test_a_failed_write_leaves_the_old_file_and_no_debris(result, tmp_path, monkeypatch):
    path = tmp_path / "out.csv"
    path.write_text("old\n")

    def broken_replace(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", broken_replace)
    with pytest.raises(OSError, match="disk full"):
        result.to_csv(path)
    assert path.read_text() == "old\n"
    assert os.listdir(tmp_path) == ["out.csv"]


def test_plot_writes_a_png(result, tmp_path):
    path = tmp_path / "plot.png"
    plot_outputs(result, path)
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000


def test_latch_labels_of_latches_close_in_time_do_not_overlap(result):
    """Four hinges latching within 0.01 s (their labels were drawn over one another: 'hphb')
    and one alone: every label clear of the others, the lone one in the first row."""
    import dataclasses
    import itertools

    from depsim.runtime.plot import outputs_figure
    from depsim.runtime.results import EventRecord

    latches = [EventRecord(f"{h}.latch", t, kind="latch", hinge=h) for h, t in
               (("h1", 0.300), ("hp", 0.302), ("hb", 0.305), ("h12", 0.309), ("h4", 0.6))]
    figure = outputs_figure(dataclasses.replace(result, events=tuple(latches)))
    figure.canvas.draw()
    renderer = figure.canvas.get_renderer()
    labels = {t.get_text(): t for t in figure.axes[0].texts}
    assert set(labels) == {"h1", "hp", "hb", "h12", "h4"}
    boxes = {name: text.get_window_extent(renderer) for name, text in labels.items()}
    for a, b in itertools.combinations(boxes, 2):
        assert not boxes[a].overlaps(boxes[b]), (a, b)
    assert labels["h4"].xyann == labels["h1"].xyann == (2, -10)


def test_output_grid_includes_t_end(pendulum):
    assert np.allclose(simulate(pendulum, t_end=1.0, dt_out=0.3).times, [0, 0.3, 0.6, 0.9, 1.0])
    assert np.allclose(simulate(pendulum, t_end=1.0, dt_out=0.25).times,
                       [0, 0.25, 0.5, 0.75, 1.0])
    short = variant(pendulum, T_END=0.3, DT_OUT=0.1, TOL=1e-7)
    run = simulate(short)  # defaults from the module
    assert (run.t_end, run.dt_out, run.tol) == (0.3, 0.1, 1e-7)
    assert np.allclose(run.times, [0, 0.1, 0.2, 0.3]) and run.times[-1] == 0.3
    assert run.q.shape == (4, 3) and run.lam.shape == (4, 2)
    assert run.hinge_angles.shape == (4, 1) and run.energy.shape == (4, 2)
    assert "pendulum: 4 output times" in run.report()


def test_result_columns_are_consistent(result, pendulum):
    p = result.parameters
    q, qd = result.q[3], result.qd[3]
    assert np.allclose(result.outputs[3], pendulum.outputs(q, qd, result.times[3], p, result.lam[3],
                                                             np.zeros(len(pendulum.RUN_VALUES))))
    assert np.allclose(result.hinge_angles[3], pendulum.hinge_angles(q, p))
    with pytest.raises(KeyError, match="no output 'nope'"):
        result.output("nope")


class FakeTerminal(io.StringIO):
    def isatty(self):
        return True


def test_progress_bar_only_on_a_terminal(monkeypatch):
    monkeypatch.setattr(progress_module, "DELAY", 0.0)
    monkeypatch.setattr(progress_module, "INTERVAL", 0.0)
    silent = io.StringIO()
    bar = progress_module.Progress(10.0, True, stream=silent)
    bar.update(5.0)
    bar.close()
    assert silent.getvalue() == ""
    terminal = FakeTerminal()
    bar = progress_module.Progress(10.0, True, stream=terminal)
    bar.update(5.0)
    assert "50.0%" in terminal.getvalue()
    bar.close()
    assert terminal.getvalue().endswith("\r")
    quiet = FakeTerminal()
    progress_module.Progress(10.0, False, stream=quiet).update(5.0)
    assert quiet.getvalue() == ""


def test_runtime_imports_neither_sympy_nor_the_compiler():
    import subprocess
    import sys

    code = ("import sys, depsim.runtime, depsim.runtime.plot, depsim.runtime.runner, "
            "depsim.runtime.binding, depsim.runtime.sweep; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] == 'sympy' "
            "or m.startswith(('depsim.dsl', 'depsim.codegen'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == "[]"
