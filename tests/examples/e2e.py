"""Helpers for end-to-end tests: run the real `depsim` command in a subprocess."""

import subprocess
import sys
from pathlib import Path


ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"


def run_cli(*args, cwd=None, timeout=600):
    """Run `python -m depsim ARGS`; returns the CompletedProcess (text mode)."""
    return subprocess.run([sys.executable, "-m", "depsim", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=timeout)
