"""The FMU at a tolerance near round-off: the importer's tolerance sets the run's tol, and the
four-bar's loop is assembled to round-off-aware limits at tol 1e-12 as in `depsim run`
(docs/method.md, 6a)."""

from __future__ import annotations

import math


def test_the_four_bar_initialises_and_steps_at_tol_1e_12(fmu_path, slave):
    s = slave(fmu_path("fourbar"))
    s.fmu.setupExperiment(tolerance=1e-12, startTime=0.0)
    s.fmu.enterInitializationMode()
    s.fmu.exitInitializationMode()
    assert s.real("crank_angle") == math.radians(60)  # the given angle, held
    for k in range(10):
        s.fmu.doStep(0.01 * k, 0.01)
    assert s.log.errors() == []
    assert math.isfinite(s.real("rocker_angle"))
