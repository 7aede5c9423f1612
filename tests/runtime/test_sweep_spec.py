"""Study specifications: grid and sample parsing, designs, reproducibility (no processes)."""

import numpy as np
import pytest

from depsim.runtime.sweep import SweepSpecError, make_design, parse_grid, parse_sample

NAMES = ("k", "c", "m", "x0", "h1.friction")
DEFAULTS = np.array([4.0, 0.1, 1.0, 1.0, 0.5])


def test_grid_is_full_factorial_first_item_slowest():
    d = make_design(NAMES, DEFAULTS, grid=["k=1:3:3", "c=0:0.2:2"])
    assert d.runs == 6 and d.varied == ("k", "c") and d.kind == "grid"
    assert d.values("k").tolist() == [1, 1, 2, 2, 3, 3]
    assert d.values("c").tolist() == [0, 0.2, 0, 0.2, 0, 0.2]
    assert (d.values("m") == 1.0).all() and d.seed is None
    assert d.spec == "grid k=1.0:3.0:3; grid c=0.0:0.2:2"


def test_grid_accepts_mapping_and_tuples():
    d = make_design(NAMES, DEFAULTS, grid={"k": (1, 2, 2), "h1.friction": "0.4:0.6:3"})
    assert d.runs == 6 and d.values("h1.friction")[:3].tolist() == [0.4, 0.5, 0.6]


def test_samples_reproducible_and_per_parameter_streams():
    a = make_design(NAMES, DEFAULTS, samples=["k=normal(4, 0.5)", "c=uniform(0, 1)"],
                    runs=200, seed=7)
    b = make_design(NAMES, DEFAULTS, samples=["c=uniform(0, 1)", "k=normal(4, 0.5)"],
                    runs=200, seed=7)
    assert np.array_equal(a.values("k"), b.values("k"))  # order of items does not matter
    assert np.array_equal(a.values("c"), b.values("c"))
    c = make_design(NAMES, DEFAULTS, samples=["k=normal(4, 0.5)"], runs=400, seed=7)
    assert np.array_equal(c.values("k")[:200], a.values("k"))  # more runs extend, not reshuffle
    d = make_design(NAMES, DEFAULTS, samples=["k=normal(4, 0.5)"], runs=200, seed=8)
    assert not np.array_equal(d.values("k"), a.values("k"))
    assert a.seed == 7 and "seed=7" in a.spec and "runs=200" in a.spec


def test_seed_none_is_drawn_and_recorded():
    a = make_design(NAMES, DEFAULTS, samples=["k=normal(4, 0.5)"], runs=5)
    assert isinstance(a.seed, int) and a.seed >= 0
    b = make_design(NAMES, DEFAULTS, samples=["k=normal(4, 0.5)"], runs=5, seed=a.seed)
    assert np.array_equal(a.matrix, b.matrix)


def test_distributions_have_the_right_shape():
    d = make_design(NAMES, DEFAULTS, runs=20000, seed=1, samples=[
        "k=normal(4, 0.5)", "c=uniform(0.1, 0.3)", "m=lognormal(2, 0.1)",
        "x0=triangular(0, 0.25, 1)"])
    k, c, m, x0 = (d.values(n) for n in ("k", "c", "m", "x0"))
    assert abs(k.mean() - 4) < 0.02 and abs(k.std() - 0.5) < 0.02
    assert c.min() >= 0.1 and c.max() <= 0.3 and abs(c.mean() - 0.2) < 0.005
    assert abs(np.median(m) - 2) < 0.02 and abs(np.log(m).std() - 0.1) < 0.005
    assert x0.min() >= 0 and x0.max() <= 1 and abs(x0.mean() - (0 + 0.25 + 1) / 3) < 0.01


def test_grid_times_samples_uses_common_random_numbers():
    d = make_design(NAMES, DEFAULTS, grid=["k=1:2:2"], samples=["c=uniform(0, 1)"], runs=3,
                    seed=3)
    assert d.runs == 6 and d.kind == "grid x monte_carlo"
    assert d.values("k").tolist() == [1, 1, 1, 2, 2, 2]
    assert np.array_equal(d.values("c")[:3], d.values("c")[3:])


def test_quantity_hook_converts_units():
    def quantity(name, text):
        number, unit = text.split()
        return float(number) * {"N*m": 1.0, "mN*m": 1e-3}[unit]

    d = make_design(NAMES, DEFAULTS, grid=["h1.friction=400 mN*m:0.6 N*m:3"], quantity=quantity)
    assert np.allclose(d.values("h1.friction"), [0.4, 0.5, 0.6])
    s = parse_sample("h1.friction=normal(0.5 N*m, 50 mN*m)", quantity)
    assert s.args == (0.5, 0.05)
    with pytest.raises(SweepSpecError, match="STOP '3 furlongs'"):
        parse_grid("h1.friction=1:3 furlongs:3", quantity)


@pytest.mark.parametrize("item, message", [
    ("k", "expected NAME="),
    ("k=1:2", "expected NAME=START:STOP:N"),
    ("k=1:2:0", "N '0' must be a positive integer"),
    ("k=1:2:2.5", "N '2.5' must be a positive integer"),
    ("k=a:2:3", "START 'a' is not a plain number"),
    ("k=1:inf:3", "STOP 'inf' is not a plain number"),
    ("k=1:2:1", "N is 1 but START != STOP"),
    ("2k=1:2:3", "'2k' is not a parameter name"),
    ("k=1 N*m:2:3", "START '1 N*m' is not a plain number"),
])
def test_bad_grid_items(item, message):
    with pytest.raises(SweepSpecError, match=message.replace("*", r"\*")):
        parse_grid(item)


@pytest.mark.parametrize("item, message", [
    ("k=gauss(1, 2)", "unknown distribution 'gauss'"),
    ("k=normall(1, 2)", "did you mean 'normal'"),
    ("k=normal(1)", r"normal takes 2 arguments normal\(MU, SIGMA\), got 1"),
    ("k=normal()", "got 0"),
    ("k=normal(1, -2)", "SIGMA must be >= 0"),
    ("k=uniform(2, 1)", "needs A <= B"),
    ("k=lognormal(0, 0.1)", "MEDIAN must be > 0"),
    ("k=triangular(0, 2, 1)", "needs A <= MODE <= B"),
    ("k=normal(1, 2", "is not a distribution"),
    ("k=normal(__import__('os'), 1)", "arguments must be numbers"),
    ("k=normal(1+1, 2)", "MU '1\\+1' is not a plain number"),
    ("k=4", "'4' is not a distribution"),
])
def test_bad_sample_items(item, message):
    with pytest.raises(SweepSpecError, match=message):
        parse_sample(item)


@pytest.mark.parametrize("kwargs, message", [
    (dict(grid=["kk=1:2:2"]), "unknown parameter 'kk'; did you mean 'k'"),
    (dict(grid=["k=1:2:2"], samples=["k=normal(1, 1)"], runs=2),
     "parameter 'k' is already varied by 'k=1:2:2'"),
    (dict(samples=["k=normal(1, 1)"]), "samples need a run count"),
    (dict(samples=["k=normal(1, 1)"], runs=0), "runs 0: must be a positive integer"),
    (dict(samples=["k=normal(1, 1)"], runs=2.5), "runs 2.5"),
    (dict(grid=["k=1:2:2"], runs=10), "runs=10 without any sample item"),
    (dict(samples=["k=normal(1, 1)"], runs=2, seed=-1), "seed -1"),
    (dict(grid=["k=1:2:5000", "c=0:1:5000"]), "surely a typo"),
])
def test_bad_designs(kwargs, message):
    with pytest.raises(SweepSpecError, match=message):
        make_design(NAMES, DEFAULTS, **kwargs)


def test_no_items_is_one_run_of_the_defaults():
    d = make_design(NAMES, DEFAULTS)
    assert d.runs == 1 and np.array_equal(d.matrix[0], DEFAULTS) and d.kind == "single"
