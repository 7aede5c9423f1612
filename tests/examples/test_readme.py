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
