"""The core's step dump (-DDEP_DUMP, run/steps.c; read by bench/beam_modes.py): it builds
warning-free under strict C99 with the trace, and each record is what the step measured its
error on: the tangential part lies in the rows' tangent space at the step's end (Phi_q e = 0
to round-off), M and W's K are symmetric with M positive definite, and the constrained
mechanism's modes (K phi = omega^2 M phi on Phi_q's null space) rebuild that error."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import scipy.linalg as sl

from depsim.codegen.c_emit import c_program_name, compile_c
from depsim.dsl import load_model

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
sys.path.insert(0, str(ROOT / "bench"))
from beam_modes import records  # noqa: E402  (the dump's format is defined by its reader)

FLAGS = "-O2 -std=c99 -Wall -Wextra -Wpedantic -Werror -DDEP_TRACE -DDEP_DUMP"


def test_the_step_dump_holds_what_the_error_was_measured_on(tmp_path):
    model = load_model(EXAMPLES / "two_link_flex.dep")
    folder = compile_c(model, tmp_path / "program")
    subprocess.run(["make", "-s", "-C", str(folder), f"CFLAGS={FLAGS}", c_program_name(model)],
                   check=True, capture_output=True)
    dump = tmp_path / "steps.bin"
    env = dict(os.environ, DEP_DUMP=str(dump), DEP_DUMP_FROM="0.01", DEP_DUMP_SPAN="0.01")
    done = subprocess.run([str(folder / c_program_name(model)), "--t-end", "0.03",
                           "--stepping", "implicit", "-o", str(tmp_path / "out.csv")],
                          env=env, capture_output=True, text=True, check=True)
    assert "step t=" in done.stderr  # the trace
    found = list(records(dump))
    assert len(found) > 5
    assert all(0.01 <= record[0] < 0.02 for record in found)
    for t, h, y1, scale, e, error, M, K, J in found:
        assert np.allclose(M, M.T, rtol=0, atol=1e-14 * np.abs(M).max())
        assert np.allclose(K, K.T, rtol=0, atol=1e-12 * np.abs(K).max())
        assert np.linalg.eigvalsh(M).min() > 0
        # the passes' projection leaves no part along the rows (relative to round-off of e)
        assert np.abs(J @ e).max() <= 1e-10 * np.abs(J).max() * np.abs(e).max()
        assert 0 < np.linalg.norm(e) <= 10 * np.linalg.norm(error)
        N = sl.null_space(J)
        _, V = sl.eigh(N.T @ K @ N, N.T @ M @ N)
        Phi = N @ V
        rebuilt = Phi @ (Phi.T @ M @ e)
        assert np.allclose(rebuilt, e, rtol=0, atol=1e-8 * np.abs(e).max())
