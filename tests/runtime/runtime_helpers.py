"""Helpers for the runtime tests: hand-made modules (tests/runtime/models), variants, the
exact pendulum period, model text compiled, a spatial body's rotation matrices."""

import importlib.util
import types
from pathlib import Path

import numpy as np
from scipy.special import ellipk

import depsim

MODELS = Path(__file__).parent / "models"


def load_handmade(name: str):
    """Import tests/runtime/models/<name>.py as a module object."""
    spec = importlib.util.spec_from_file_location(f"handmade_{name}", MODELS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def variant(module, **overrides):
    """A copy of a module's namespace with some names replaced (a modified 'module')."""
    names = {k: v for k, v in vars(module).items() if not k.startswith("__")}
    names.update(overrides)
    return types.SimpleNamespace(**names)


def pendulum_period(p) -> float:
    """Exact large-amplitude period T = 4 sqrt(J_O / (m g d)) K(k), k = sin(theta0 / 2)."""
    L, m, g, theta0 = p[0], p[1], p[2], p[3]
    d = L / 2
    J_O = m * L * L / 12 + m * d * d
    k = np.sin(theta0 / 2)
    return 4 * np.sqrt(J_O / (m * g * d)) * ellipk(k * k)  # scipy's ellipk takes m = k^2




def compile_text(tmp_path, name: str, text: str, target: str = "c"):
    """Model text written to tmp_path/<name>.dep, compiled for `target`."""
    path = tmp_path / f"{name}.dep"
    path.write_text(text)
    return depsim.load(path).compile(target, out_dir=tmp_path / f"{name}_{target}")


def rotations(result, body: str) -> np.ndarray:
    """A spatial body's rotation matrices R (n, 3, 3) at the output times."""
    names = result.coordinate_names
    columns = [names.index(f"{body}.R{i}{j}") for i in "123" for j in "123"]
    return result.q[:, columns].reshape(-1, 3, 3)
