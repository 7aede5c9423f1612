"""The command line under bad arguments and awkward outputs: every bad
argument a clear `depsim: error: ...` and exit code 2 (usage; 1 stays for model errors), no
traceback, nothing written half, no file clobbered; output paths keep what they are (links,
pipes, descriptors); a killed sweep takes its workers with it."""

import contextlib
import os
import shutil
import signal
import stat
import subprocess
import sys
import time

import pytest

from e2e import EXAMPLES

PENDULUM = EXAMPLES / "pendulum.dep"
SHORT = ("--t-end", "0.2")


def assert_usage_error(done, *fragments):
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr
    for fragment in fragments:
        assert fragment in done.stderr


# --- settings ------------------------------------------------------------------------------

@pytest.mark.parametrize("command", ["run", "sweep"])
@pytest.mark.parametrize("tol", ["1", "2"])
def test_tol_must_lie_between_0_and_1(cli, tmp_path, command, tol):
    done = cli(command, PENDULUM, *SHORT, "--tol", tol, "-o", tmp_path / "out")
    assert_usage_error(done, "--tol", "between 0 and 1")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("command", ["run", "sweep"])
def test_too_many_output_times_are_refused_before_running(cli, tmp_path, command):
    done = cli(command, PENDULUM, "--dt-out", "1e-9", "--t-end", "10", "-o", tmp_path / "out")
    assert_usage_error(done, "--t-end / --dt-out", "10,000,000,001 output times",
                       "limit of 10,000,000", "dt_out >= 1e-06 s")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("setting, message", [
    ("r=-1", "crank.length must be positive, got -1 m (from r=-1)"),
    ("crank_pin.stiffness=-2", "crank_pin.stiffness must not be negative, got -2 N*m/rad"),
])
def test_set_values_pass_the_model_texts_range_checks(cli, tmp_path, setting, message):
    done = cli("run", EXAMPLES / "slider_crank.dep", "--set", setting, "--t-end", "0.01",
               "-o", tmp_path / "out.csv")
    assert_usage_error(done, message)
    assert list(tmp_path.iterdir()) == []


def test_a_value_error_of_the_runtime_is_a_usage_error(tmp_path, monkeypatch, capsys):
    """What simulate refuses (ValueError, e.g. the bound on output rows the runner checks
    too) reaches the user as a message, not a traceback."""
    from depsim import api, cli

    def refuse(*args, **kwargs):
        raise ValueError("tol must lie between 0 and 1, got 1.0")

    monkeypatch.setattr(api.Simulator, "run", refuse)
    assert cli.main(["run", str(PENDULUM), *SHORT, "-o", str(tmp_path / "o.csv")]) == 2
    assert "depsim: error: tol must lie between 0 and 1" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


# --- output paths, checked before anything runs --------------------------------------------

@pytest.mark.parametrize("options, message", [
    (["-o", "no/such/dir/o.csv"], "cannot write no/such/dir/o.csv: folder 'no/such/dir' does "
                                  "not exist"),
    (["-o", "."], "cannot write .: it is a folder"),
    (["-o", "a.csv", "--summary", "no/s.json"], "folder 'no' does not exist"),
    (["--plot", "no/p.png"], "folder 'no' does not exist"),
    (["--plot", "p.xyz"], "unknown format '.xyz'; use one of .png, .pdf, .svg"),
    (["--animate", "a.xyz"], "unknown format '.xyz'; use one of .gif, .mp4"),
    (["-o", "x.csv", "--summary", "x.csv"], "--summary x.csv: that is the file of -o"),
])
def test_bad_output_paths_are_refused_and_nothing_is_written(cli, tmp_path, options, message):
    done = cli("run", PENDULUM, *SHORT, *options, cwd=tmp_path)
    assert_usage_error(done, "depsim: error: ", message)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs /proc (Linux)")
def test_an_unwritable_place_is_refused(cli, tmp_path):
    # /proc takes no new files, not even from root
    done = cli("run", PENDULUM, *SHORT, "--summary", tmp_path / "a.json",
               "-o", "/proc/depsim.csv")
    assert_usage_error(done, "cannot write /proc/depsim.csv: no file can be created")
    assert list(tmp_path.iterdir()) == []
    done = cli("compile", PENDULUM, "-o", "/proc/depsim-test/out")
    assert_usage_error(done, "depsim: error: ")


def test_the_model_file_is_never_an_output(cli, tmp_path):
    model = tmp_path / "pendulum.dep"
    shutil.copy(PENDULUM, model)
    done = cli("run", model, *SHORT, "-o", model)
    assert_usage_error(done, "that is the model file")
    assert model.read_bytes() == PENDULUM.read_bytes()


def test_compile_onto_a_file_is_a_usage_error(cli, tmp_path):
    taken = tmp_path / "taken"
    taken.write_text("mine\n")
    for target in ("numpy", "c"):
        done = cli("compile", PENDULUM, "--target", target, "-o", taken)
        assert_usage_error(done, "is not a folder")
    assert taken.read_text() == "mine\n"


def test_sweep_output_into_a_missing_folder(cli, tmp_path):
    done = cli("sweep", PENDULUM, "--grid", "L=1:2:2", *SHORT, "-o", "no/such/s.nc",
               cwd=tmp_path)
    assert_usage_error(done, "cannot write no/such/s.nc: folder 'no/such' does not exist")
    done = cli("sweep", PENDULUM, "--grid", "L=1:2:2", *SHORT, "--plot", "s.xyz",
               cwd=tmp_path)
    assert_usage_error(done, "unknown format '.xyz'")
    assert list(tmp_path.iterdir()) == []


def test_an_mp4_without_ffmpeg_is_refused_before_running(tmp_path, monkeypatch, capsys):
    import matplotlib

    from depsim import api, cli

    monkeypatch.setitem(matplotlib.rcParams, "animation.ffmpeg_path", str(tmp_path / "none"))
    monkeypatch.setattr(api.Model, "compile", lambda *a, **k: pytest.fail("it ran"))
    assert cli.main(["run", str(PENDULUM), *SHORT, "--animate", str(tmp_path / "a.mp4")]) == 2
    assert "an MP4 needs ffmpeg" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


# --- all outputs or none -------------------------------------------------------------------

def test_a_failing_output_takes_the_others_with_it(tmp_path, monkeypatch, capsys):
    import depsim.runtime
    from depsim import cli

    def disk_full(result, module, path, **options):
        raise OSError(28, "No space left on device", str(path))

    monkeypatch.setattr(depsim.runtime, "animate", disk_full)
    out, summary = tmp_path / "o.csv", tmp_path / "o.json"
    out.write_text("old\n")
    code = cli.main(["run", str(PENDULUM), *SHORT, "-o", str(out), "--summary", str(summary),
                     "--animate", str(tmp_path / "o.gif")])
    assert code == 2
    assert "No space left on device" in capsys.readouterr().err
    assert out.read_text() == "old\n"  # neither replaced nor removed
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o.csv"]  # no json, no debris


def test_all_or_none_takes_back_files_already_put_in_place(tmp_path, monkeypatch):
    from depsim.runtime import output

    first, second = tmp_path / "first.txt", tmp_path / "second.txt"
    real_replace, calls = os.replace, []

    def replace_once(src, dst):
        calls.append(dst)
        if len(calls) == 2:
            raise OSError(5, "Input/output error")
        real_replace(src, dst)

    monkeypatch.setattr(os, "replace", replace_once)
    with pytest.raises(output.OutputError, match="cannot write .*second.txt"):
        with output.all_or_none():
            for path in (first, second):
                with output.atomic_path(path) as tmp, open(tmp, "w") as handle:
                    handle.write("new\n")
    assert list(tmp_path.iterdir()) == []


def test_sweep_writes_the_study_and_its_plot_or_neither(tmp_path, monkeypatch, capsys):
    import depsim.runtime.sweep
    from depsim import cli

    def broken_plot(ds, path, **options):
        raise OSError(28, "No space left on device", str(path))

    args = ["sweep", str(PENDULUM), "--grid", "L=1:2:3", *SHORT, "--scheduler", "inline",
            "-o", str(tmp_path / "s.nc"), "--plot", str(tmp_path / "s.png")]
    monkeypatch.setattr(depsim.runtime.sweep, "plot_study", broken_plot)
    assert cli.main(args) == 2
    err = capsys.readouterr().err
    assert "No space left on device" in err and "run again with --resume" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.nc.partial"]  # runs kept
    monkeypatch.undo()
    assert cli.main(args + ["--resume"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.nc", "s.png"]


# --- what a path is, it stays ----------------------------------------------------------------

def test_output_through_a_symlink_writes_its_target(cli, tmp_path):
    target, link = tmp_path / "target.csv", tmp_path / "link.csv"
    target.write_text("old\n")
    target.chmod(0o600)
    link.symlink_to(target.name)
    done = cli("run", PENDULUM, *SHORT, "-o", link)
    assert done.returncode == 0, done.stderr
    assert link.is_symlink() and os.readlink(link) == "target.csv"
    assert target.read_text().startswith("t,theta,")
    assert stat.S_IMODE(target.stat().st_mode) == 0o600  # the file keeps its permissions


def test_output_into_a_fifo_writes_through_it(cli, tmp_path):
    fifo = tmp_path / "out.csv"
    os.mkfifo(fifo)
    reader = subprocess.Popen(["cat", str(fifo)], stdout=subprocess.PIPE)
    try:
        done = cli("run", PENDULUM, *SHORT, "-o", fifo)
        assert done.returncode == 0, done.stderr
        read, _ = reader.communicate(timeout=30)
    finally:
        reader.kill()
        reader.wait()
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert read.startswith(b"t,theta,omega,tip_x,tip_y\n0,")


@pytest.mark.skipif(not os.path.isdir("/dev/fd"), reason="needs /dev/fd")
def test_output_to_a_descriptor_is_written_through_it(tmp_path):
    read_end, write_end = os.pipe()
    try:
        done = subprocess.run([sys.executable, "-m", "depsim", "run", str(PENDULUM), *SHORT,
                               "-o", f"/dev/fd/{write_end}", "--summary", "/dev/null"],
                              pass_fds=(write_end,), capture_output=True, text=True,
                              timeout=600)
        os.close(write_end)
        with os.fdopen(read_end, "rb") as pipe:
            read = pipe.read()
    finally:
        for fd in (read_end, write_end):
            with contextlib.suppress(OSError):
                os.close(fd)
    assert done.returncode == 0, done.stderr
    assert read.startswith(b"t,theta,omega,tip_x,tip_y\n0,")
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)


@pytest.mark.parametrize("name, magic", [("p.pdf", b"%PDF"), ("p.svg", b"<?xml")])
def test_plot_format_follows_the_extension(cli, tmp_path, name, magic):
    done = cli("run", PENDULUM, *SHORT, "--plot", tmp_path / name)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / name).read_bytes().startswith(magic)


# --- errors are fast ---------------------------------------------------------------------------

def test_a_failing_check_imports_neither_sympy_nor_scipy(tmp_path):
    bad = tmp_path / "bad.dep"
    bad.write_text("model x\nbar b {\n    length = 1 m\n    mas = 2\n}\n")
    probe = ("import sys\nfrom depsim.cli import main\ncode = main(['check', sys.argv[1]])\n"
             "print(code, sorted(m for m in ('sympy', 'scipy', 'depsim.codegen') "
             "if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", probe, str(bad)], capture_output=True,
                          text=True, timeout=600)
    assert "error[E020]" in done.stderr
    assert done.stdout.split(None, 1) == ["1", "[]\n"]


# --- studies -------------------------------------------------------------------------------

def test_resume_from_a_truncated_study_file_refuses_and_keeps_it(cli, tmp_path):
    study = tmp_path / "s.nc"
    study.write_bytes(b"\x89HDF\r\n\x1a\n" + bytes(100))  # the start of a file, cut short
    done = cli("sweep", PENDULUM, "--grid", "L=1:2:2", *SHORT, "--workers", "1",
               "-o", study, "--resume")
    assert_usage_error(done, f"{study} is not a readable study file (truncated?)",
                       "nothing was run or changed", "without resume (--resume)")
    assert study.read_bytes() == b"\x89HDF\r\n\x1a\n" + bytes(100)
    assert list(tmp_path.iterdir()) == [study]


def _process_group(group: int) -> list[int]:
    """Live (not zombie) processes in process group `group`."""
    members = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as handle:
                fields = handle.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == group and fields[0] != "Z":
            members.append(int(entry))
    return members


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_a_killed_sweep_takes_its_workers_with_it(tmp_path):
    out = tmp_path / "s.nc"
    partial = tmp_path / "s.nc.partial"
    sweep = subprocess.Popen([sys.executable, "-m", "depsim", "sweep", str(PENDULUM),
                              "--grid", "L=0.5:1.5:2000", "--t-end", "50", "--workers", "2",
                              "-o", str(out)], stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.monotonic() + 300
        while sweep.poll() is None and time.monotonic() < deadline:  # runs are coming back
            if partial.exists() and len(partial.read_text().splitlines()) > 1:
                break
            time.sleep(0.05)
        assert sweep.poll() is None, "the study ended before it could be killed"
        assert len(_process_group(sweep.pid)) >= 3  # the study, its workers, the tracker
        sweep.send_signal(signal.SIGKILL)
        sweep.wait()
        deadline = time.monotonic() + 10
        while _process_group(sweep.pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert _process_group(sweep.pid) == []
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(sweep.pid, signal.SIGKILL)
        sweep.wait()


# --- runs that would grind ------------------------------------------------------------------

STIFF = """model stiff_pair "a double pendulum whose second hinge is stiff and heavily damped"
gravity = (0, -9.81) m/s^2
bar upper { length = 1 m; mass = 2 kg; inertia = 2 kg*m^2/12 }
bar lower { length = 1 m; mass = 2 kg; inertia = 2 kg*m^2/12 }
hinge h1 joins ground.origin to upper.a { }
hinge h2 joins upper.b to lower.a { stiffness = 1e6 N*m/rad; damping = 1e5 N*m*s/rad }
initial { h1 = 30 deg }
simulate { t_end = 10 s; tol = 1e-8; dt_out = 0.01 s }
output theta1 = h1
"""


def test_a_stiff_run_stops_early_and_max_steps_lets_it_run(cli, tmp_path):
    model = tmp_path / "stiff_pair.dep"
    model.write_text(STIFF)
    done = cli("run", model, "-o", tmp_path / "o.csv")
    assert done.returncode == 3 and "Traceback" not in done.stderr
    assert "the model is stiff here" in done.stderr and "--max-steps" in done.stderr
    assert not (tmp_path / "o.csv").exists()
    done = cli("run", model, "--t-end", "0.05", "--max-steps", "2e6", "-o", tmp_path / "o.csv")
    assert done.returncode == 0, done.stderr
    assert float((tmp_path / "o.csv").read_text().splitlines()[-1].split(",")[0]) == 0.05
