"""Outputs that leave their functions' domain during a run (sqrt or log of a negative value,
acos beyond 1, a division by a state that reaches zero): nan or inf in the output, the same in
both targets (IEEE arithmetic, as C computes), and one warning per output in the report,
never a traceback."""

import math
import warnings

import numpy as np
import pytest

import depsim

MODEL = """model domain "outputs that leave their domain while the bar swings"
gravity = (0, -9.81) m/s^2
bar rod { length = 1 m; mass = 2 kg; inertia = 2 kg*m^2/12 }
hinge pivot joins ground.origin to rod.a { }
initial { pivot = 60 deg }
simulate { t_end = 2 s; tol = 1e-8; dt_out = 0.01 s }
output theta = pivot
output root = sqrt(pivot / rad)
output logarithm = log(pivot / rad)
output arc = acos(2 * pivot / rad)
output inverse = rad / pivot
"""


@pytest.fixture(scope="module")
def sims(tmp_path_factory):
    folder = tmp_path_factory.mktemp("domain")
    (folder / "domain.dep").write_text(MODEL)
    model = depsim.load(folder / "domain.dep")
    return {target: model.compile(target, out_dir=folder / target) for target in ("numpy", "c")}


@pytest.fixture(scope="module")
def results(sims):
    return {target: sim.run() for target, sim in sims.items()}


@pytest.mark.parametrize("target", ["numpy", "c"])
def test_outputs_outside_their_domain_are_nan_and_reported(results, target):
    result = results[target]
    theta = result.output("theta")
    assert np.any(theta < 0) and np.all(np.isfinite(theta))  # the bar swings through 0
    assert np.array_equal(np.isnan(result.output("root")), theta < 0)
    assert np.array_equal(np.isnan(result.output("logarithm")), theta < 0)
    assert np.array_equal(np.isnan(result.output("arc")), np.abs(2 * theta) > 1)
    finite = theta >= 0
    assert np.allclose(result.output("root")[finite], np.sqrt(theta[finite]), rtol=1e-15)
    report = result.report()
    first = result.times[np.argmax(theta < 0)]
    assert (f"warning: output root is nan at {np.sum(theta < 0)} of {len(theta)} output "
            f"times, first at t = {first:.9g} s") in report
    assert "warning: output arc is nan" in report and "warning: output theta" not in report


def test_both_targets_agree_on_the_nan_pattern(results):
    a, b = results["numpy"].outputs, results["c"].outputs
    assert np.array_equal(np.isnan(a), np.isnan(b))
    assert np.allclose(a[np.isfinite(a)], b[np.isfinite(b)], rtol=1e-9, atol=1e-12)


def test_the_numpy_module_gives_ieee_values_without_raising_or_warning(sims):
    module = sims["numpy"].module
    p = np.array(module.PARAMETER_DEFAULTS)
    index = module.COORDINATES.index("rod.phi")
    for angle in (0.0, -0.5):  # pivot = rod.phi: 0 exactly, then negative
        q = np.zeros(module.NQ)
        q[index] = angle
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            y = module.outputs(list(q), [0.0] * module.NQ, 0.0, list(p), [0.0] * module.NC,
                               [0.0] * len(module.RUN_VALUES))
        theta, root, logarithm, arc, inverse = y
        assert theta == pytest.approx(angle, abs=1e-15)
        if angle == 0.0:
            assert root == 0.0 and logarithm == -math.inf and math.isinf(inverse)
        else:
            assert math.isnan(root) and math.isnan(logarithm) and inverse == pytest.approx(-2)
        assert arc == pytest.approx(math.acos(2 * angle)) if abs(2 * angle) <= 1 else math.isnan(arc)
