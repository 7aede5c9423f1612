"""README.md stays true: its model snippet checks clean and its commands exist."""

import re

from e2e import ROOT


def test_readme_model_snippet_checks_clean(cli, tmp_path):
    readme = (ROOT / "README.md").read_text()
    snippet = re.search(r"## A model\s+```\n(.*?)```", readme, re.S).group(1)
    model = tmp_path / "snippet.dep"
    model.write_text(snippet)
    done = cli("check", model)
    assert done.returncode == 0, done.stderr


def test_readme_quick_start_is_make_demo_and_make_test():
    readme = (ROOT / "README.md").read_text()
    quick = readme.split("## Quick start")[1].split("##")[0]
    assert "make demo" in quick and "make test" in quick
    makefile = (ROOT / "Makefile").read_text()
    assert re.search(r"^demo:", makefile, re.M) and re.search(r"^test:", makefile, re.M)


def test_readme_python_snippet_runs_as_a_script(tmp_path):
    """The README's Python section, saved as a file and run as a script (no main guard): it
    simulates, then runs its study on the C target in a local process pool."""
    import shutil
    import subprocess
    import sys

    import xarray as xr

    readme = (ROOT / "README.md").read_text()
    snippet = re.search(r"## Python\s+```python\n(.*?)```", readme, re.S).group(1)
    assert "__main__" not in snippet and "depsim.sweep(" in snippet
    (tmp_path / "examples").mkdir()
    shutil.copy(ROOT / "examples" / "intelsat5.dep", tmp_path / "examples")
    (tmp_path / "snippet.py").write_text(snippet)
    done = subprocess.run([sys.executable, "snippet.py"], cwd=tmp_path, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr
    assert "P(not deployed)" in done.stdout and "DEPLOYED" in done.stdout
    with xr.open_dataset(tmp_path / "study.nc", engine="h5netcdf") as study:
        assert study.attrs["target"] == "c" and not study["failed"].any()
        assert study["peak.h1.torque"].attrs["units"] == "N*m"
    assert (tmp_path / "study.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (tmp_path / "intelsat5.csv").read_text().startswith("t,theta1")
    # the summary the README shows is the snippet's, line for line
    shown = readme.split("## Python")[1].split("## Documentation")[0].split("```")[2]
    table = [line.strip() for line in shown.splitlines() if line.startswith("    ")
             and line.strip() and line.strip() != "..."]
    assert len(table) == 9
    for line in table:
        assert line in done.stdout, line


def test_the_study_figure_is_there():
    for page in ("README.md", "docs/api.md"):
        text = (ROOT / page).read_text()
        (figure,) = re.findall(r"!\[[^]]*\]\(([^)]*intelsat5-study.png)\)", text)
        path = (ROOT / page).parent / figure
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", page
