"""Counts a run's work and accuracy as it goes; `stats()` freezes them into `Stats`."""

from __future__ import annotations

from .results import PassStats, Stats

PASSES = ("position", "velocity", "acceleration")


class Tally:
    def __init__(self):
        self.accepted = self.rejected = self.failed = self.events = 0
        self.cg_iterations = self.factorizations = 0
        self.totals = {name: 0 for name in PASSES}
        self.maxima = {name: 0 for name in PASSES}
        self.residuals = {name: 0.0 for name in PASSES}
        self.min_step = float("inf")
        self.max_step = 0.0

    def accept(self, reports, h: float) -> None:
        """An accepted step of size h (s) with one PassReport per pass."""
        self.accepted += 1
        self.min_step = min(self.min_step, h)
        self.max_step = max(self.max_step, h)
        for report in reports:
            self.observe(report)
            self.totals[report.stage] += report.iterations
            self.maxima[report.stage] = max(self.maxima[report.stage], report.iterations)

    def observe(self, report) -> None:
        """Residual and CG work of a pass outside a step (initial state, after events)."""
        self.cg_iterations += report.cg_iterations
        self.residuals[report.stage] = max(self.residuals[report.stage], report.errors[-1])

    def stats(self, integrations: int, rhs_evaluations: int) -> Stats:
        def pass_stats(name):
            mean = self.totals[name] / self.accepted if self.accepted else 0.0
            return PassStats(mean, self.maxima[name], self.totals[name])

        return Stats(
            accepted_steps=self.accepted, rejected_steps=self.rejected,
            failed_steps=self.failed, integrations=integrations,
            rhs_evaluations=rhs_evaluations, position=pass_stats("position"),
            velocity=pass_stats("velocity"), acceleration=pass_stats("acceleration"),
            cg_iterations=self.cg_iterations, factorizations=self.factorizations,
            max_v_pos=self.residuals["position"], max_v_vel=self.residuals["velocity"],
            max_v_acc=self.residuals["acceleration"],
            min_step=self.min_step if self.accepted else 0.0, max_step=self.max_step,
            events=self.events)
