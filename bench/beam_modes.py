"""What the linearly implicit step's error is made of, mode by mode (docs/method.md, 10).

Builds a model's standalone program with the core's step dump (-DDEP_DUMP, run/steps.c), runs
it, and splits the error each step was measured on (the filtered embedded estimate's
tangential part, positions) by the modes of the constrained mechanism: K phi = omega^2 M phi
on the null space of Phi_q (K the stiff forces' stiffness W was made from, M the mass matrix,
both at the step's end). For each mode it prints omega, h omega and the RMS over the window of
its part of the weighted error norm (1: at tolerance), for the tangential part and for the
whole filtered error.

    .venv/bin/python bench/beam_modes.py                        # two_link_flex, 8 elements
    .venv/bin/python bench/beam_modes.py --elements 10 --tol 2e-8 --from 0.3
    .venv/bin/python bench/beam_modes.py --model examples/other.dep --elements ''
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import scipy.linalg as sl

ROOT = Path(__file__).resolve().parents[1]
CFLAGS = "-O2 -fno-math-errno -std=c99 -DDEP_DUMP"


def build(model: Path, elements: str, folder: Path) -> Path:
    out = folder / "program"
    cmd = [sys.executable, "-m", "depsim", "compile", str(model), "--target", "c", "-o", str(out)]
    if elements:
        cmd += ["--elements", elements]
    subprocess.run(cmd, check=True, capture_output=True)
    subprocess.run(["make", "-s", "-j2", "-C", str(out), f"CFLAGS={CFLAGS}"], check=True)
    programs = [p for p in out.iterdir() if p.is_file() and os.access(p, os.X_OK)
                and p.suffix == ""]
    return programs[0]


def records(path: Path):
    raw = np.fromfile(path)
    i = 0
    while i < len(raw):
        t, h, nq, nc = raw[i:i + 4]
        nq, nc = int(nq), int(nc)
        i += 4
        take = lambda n: raw[i:i + n]  # noqa: E731
        y1 = take(2 * nq); i += 2 * nq
        scale = take(nq); i += nq
        tangent = take(2 * nq); i += 2 * nq
        error = take(2 * nq); i += 2 * nq
        M = take(nq * nq).reshape(nq, nq); i += nq * nq
        K = take(nq * nq).reshape(nq, nq); i += nq * nq
        J = take(nc * nq).reshape(nc, nq); i += nc * nq
        yield t, h, y1, scale, tangent[:nq], error[:nq], M, K, J


def modes(M, K, J):
    """The constrained mechanism's modes: omega and Phi (columns, M-orthonormal)."""
    N = sl.null_space(J) if J.shape[0] else np.eye(M.shape[0])
    w2, V = sl.eigh(N.T @ K @ N, N.T @ M @ N)
    return np.sqrt(np.abs(w2)), N @ V


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default=str(ROOT / "examples" / "two_link_flex.dep"))
    parser.add_argument("--elements", default="8",
                        help="per link (link1=N,link2=N), or a compile --elements text, or ''")
    parser.add_argument("--tol", type=float, default=3e-8)
    parser.add_argument("--from", dest="start", type=float, default=3.0)
    parser.add_argument("--span", type=float, default=0.02)
    parser.add_argument("--top", type=int, default=10)
    args = parser.parse_args(argv)
    elements = (f"link1={args.elements},link2={args.elements}" if args.elements.isdigit()
                else args.elements)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        program = build(Path(args.model), elements, folder)
        dump = folder / "steps.bin"
        env = dict(os.environ, DEP_DUMP=str(dump), DEP_DUMP_FROM=repr(args.start),
                   DEP_DUMP_SPAN=repr(args.span))
        done = subprocess.run([str(program), "--tol", repr(args.tol), "-o",
                               str(folder / "out.csv")], env=env, capture_output=True,
                              text=True, check=True)
        print("\n".join(line for line in done.stdout.splitlines() if "accepted" in line))
        shares = shares_whole = None
        steps, total = 0, 0.0
        for t, h, y1, scale, tangent, error, M, K, J in records(dump):
            w, Phi = modes(M, K, J)
            parts = [(Phi * (Phi.T @ M @ e)) / scale[:, None] for e in (tangent, error)]
            squares = [np.mean(p ** 2, axis=0) for p in parts]
            shares = squares[0] if shares is None else shares + squares[0]
            shares_whole = squares[1] if shares_whole is None else shares_whole + squares[1]
            total += np.mean((tangent / scale) ** 2)
            steps += 1
        if not steps:
            print("no linearly implicit step in the window")
            return 1
        print(f"{steps} steps from t = {args.start:g} s, h = {h:.4g} s (the last); the "
              f"positions' tangential error, RMS over the steps: {np.sqrt(total / steps):.3f}")
        print("| omega rad/s | h omega | tangential part | whole filtered error |")
        print("|---|---|---|---|")
        for k in np.argsort(-shares)[:args.top]:
            print(f"| {w[k]:.0f} | {w[k] * h:.3f} | {np.sqrt(shares[k] / steps):.3f} "
                  f"| {np.sqrt(shares_whole[k] / steps):.3f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
