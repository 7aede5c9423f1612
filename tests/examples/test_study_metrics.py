"""A study of INTELSAT V carries, for every run, what the run itself reports (Result.deployment,
Result.peak_loads, the latch events, the dissipated energy, the outputs), each metric with its
unit (docs/api.md, Metrics); the parameters too."""

import math

import pytest

import depsim
from e2e import EXAMPLES


@pytest.fixture(scope="module")
def sim():
    return depsim.load(EXAMPLES / "intelsat5.dep").compile("c")


def test_a_study_measures_what_each_run_reports_in_its_units(sim):
    study = depsim.sweep(sim, grid=["h2.friction=0.6:0.7:2"], scheduler="inline")
    assert study.attrs["target"] == "c" and not study["failed"].any()
    for run, friction in enumerate((0.6, 0.7)):
        # a study without metrics of its own asks each run for its last output row alone
        # (docs/api.md): the peak loads are then the maxima over the steps
        result = sim.run(set={"h2.friction": friction}, dt_out=sim.module.T_END)
        rows = sim.run(set={"h2.friction": friction})
        for hinge, peak in rows.peak_loads.items():  # with the model's output rows too
            assert study[f"peak.{hinge}.torque"].values[run] == pytest.approx(peak.torque,
                                                                              rel=1e-9)
        deployment = result.deployment
        assert deployment.deployed and study["deployed"].values[run] == 1
        assert study["time_to_deploy"].values[run] == deployment.time
        for latch in deployment.latches:
            name = f"event.{latch.hinge}.latch"
            assert study[f"{name}.t"].values[run] == latch.t
            assert study[f"{name}.rate"].values[run] == latch.rate
            assert study[f"{name}.impulse"].values[run] == latch.impulse
            assert study[f"{name}.impact_energy_loss"].values[run] == latch.energy_loss
        for hinge, peak in result.peak_loads.items():
            for field in ("force", "t_force", "torque", "t_torque"):
                got, want = study[f"peak.{hinge}.{field}"].values[run], getattr(peak, field)
                assert got == want or (math.isnan(got) and math.isnan(want))
        assert study["dissipated.friction"].values[run] == pytest.approx(
            deployment.friction_energy, rel=1e-14)
        assert study["dissipated.impact"].values[run] == deployment.impact_energy
        assert study["final.theta2"].values[run] == result.output("theta2")[-1]
    units = {name: study[name].attrs.get("units") for name in study.data_vars}
    assert units["time_to_deploy"] == units["event.h1.latch.t"] == "s"
    assert units["event.h1.latch.rate"] == "rad/s"
    assert units["event.h1.latch.impulse"] == "N*m*s"
    assert units["event.h1.latch.impact_energy_loss"] == units["dissipated.friction"] == "J"
    assert units["peak.h1.torque"] == "N*m" and units["peak.h1.force"] == "N"
    assert units["peak.h1.t_torque"] == "s" and units["final.theta2"] == "rad"
    assert study["h2.friction"].attrs["units"] == "N*m"
    index = list(study["parameter"].values).index("cable_k")
    assert study["parameter_unit"].values[index] == "N/m"


def test_a_numpy_simulator_studies_on_the_c_target_unless_told(sim):
    numpy = depsim.load(EXAMPLES / "pendulum.dep").compile()
    study = depsim.sweep(numpy, grid=["L=0.5:1:2"], t_end=0.2, scheduler="inline")
    assert study.attrs["target"] == "c"
    study = depsim.sweep(numpy, grid=["L=0.5:1:2"], t_end=0.2, scheduler="inline",
                         target="numpy")
    assert study.attrs["target"] == "numpy"
