"""The two-link flexible pendulum's bending frequencies from `modes` against the spectrum of
a run of a finer mesh (docs/modes.md).

    .venv/bin/python bench/modes_spectrum.py [--t-end 3] [--fine 8] [--coarse 2,4,8]

The model is examples/two_link_flex.dep held straight: no gravity, both hinges held down for
the whole run (`release` beyond its end), so it is a two-link cantilever; a constant force
of 1 N across link 2's tip, applied from t = 0, sets it vibrating about its deflected shape.
`modes` at t = 0 (the holds lock both hinges) gives its frequencies at each coarse mesh; the
run of the fine mesh gives the spectrum of link 2's tip deflection (a Hann window, the peaks'
positions refined by a parabola through the three largest bins of each).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

import depsim

ROOT = Path(__file__).resolve().parents[1]


def held_model(folder: Path, elements: int) -> Path:
    text = (ROOT / "examples" / "two_link_flex.dep").read_text()
    text = text.replace("gravity = (0, -9.81) m/s^2", "")
    text = text.replace("elements        = 2", f"elements = {elements}")
    text = text.replace("h2 = 5 deg", "h2 = 0 deg")
    lines = []
    for line in text.splitlines():
        lines.append(line)
        if line.startswith("hinge ") and line.rstrip().endswith("{"):
            lines.append("    release = 1000 s")  # held down for the whole run
    text = "\n".join(lines)
    text += "\ninput shake force on link2.b = (0, 1) N\n"
    path = folder / f"held{elements}.dep"
    path.write_text(text)
    return path


def peaks(t: np.ndarray, y: np.ndarray, count: int) -> list[float]:
    """The `count` largest spectral peaks of y(t) (Hz), refined by parabolas."""
    y = (y - np.mean(y)) * np.hanning(len(y))
    spectrum = np.abs(np.fft.rfft(y))
    frequency = np.fft.rfftfreq(len(y), t[1] - t[0])
    found = []
    for k in range(2, len(spectrum) - 1):
        if spectrum[k] > spectrum[k - 1] and spectrum[k] >= spectrum[k + 1]:
            a, b, c = np.log(spectrum[k - 1:k + 2])
            shift = 0.5 * (a - c) / (a - 2 * b + c)
            found.append((spectrum[k], frequency[k] + shift * (frequency[1] - frequency[0])))
    return sorted(f for _, f in sorted(found, reverse=True)[:count])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=3.0)
    parser.add_argument("--fine", type=int, default=8)
    parser.add_argument("--coarse", default="2,4,8")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        rows = {}
        for elements in (int(n) for n in args.coarse.split(",")):
            sim = depsim.load(held_model(folder, elements)).compile(
                "c", out_dir=folder / f"c{elements}")
            found = sim.modes(count=3)
            rows[elements] = found.frequencies
            print(f"modes, {elements} elements/link: {found.locked} locked, "
                  + ", ".join(f"{f:.4f}" for f in found.frequencies) + " Hz")
        sim = depsim.load(held_model(folder, args.fine)).compile("c", out_dir=folder / "fine")
        result = sim.run(t_end=args.t_end, dt_out=2.5e-4)
        spectrum = peaks(result.times, result.output("tip2"), 3)
        print(f"spectrum of a run, {args.fine} elements/link, {args.t_end:g} s "
              f"({result.stats.accepted_steps:,} steps): "
              + ", ".join(f"{f:.4f}" for f in spectrum) + " Hz "
              f"(bins {1 / args.t_end:.3f} Hz)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
