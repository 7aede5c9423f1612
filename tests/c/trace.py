"""Print every step the Python integrator attempts (and the steps re-taken to an event), in the
format of the C integrator built with -DDEP_TRACE, to find where NumPy and C runs part when
re-syncing the C port (docs/c-target.md, section 6):

    .venv/bin/python tests/c/trace.py examples/intelsat5.dep 2.0 > py.trace
    (C: compile the folder's sources with -DDEP_TRACE and run it to t_end 2.0; stderr)
    diff py.trace c.trace | head
"""

from __future__ import annotations

import sys
import tempfile

from depsim.codegen import compile_numpy, load_generated
from depsim.dsl import load_model
from depsim.runtime import integrator, simulate
from depsim.runtime.multipliers import PassFailure


def install_trace(out=sys.stderr) -> None:
    """Wrap IterativeRun's step and error evaluation to print one line per attempt."""
    errors, stepper_step = integrator.IterativeRun._errors, integrator.Stepper.step
    fire = integrator.IterativeRun._fire

    def traced_fire(self, k, t_event, side):
        prior_t, step = self.state.t, self.stepper.step

        def event_step(state, h, lam_predicted):
            outcome = step(state, h, lam_predicted)
            out.write(f"event step t={prior_t:.17g} h={h:.17g} integrations "
                      f"{outcome.integrations}\n")
            return outcome

        self.stepper.step = event_step
        try:
            return fire(self, k, t_event, side)
        finally:
            del self.stepper.step

    def traced_errors(self, outcome, h):
        err_ode, err_lam = errors(self, outcome, h)
        verdict = "accepted" if err_ode + err_lam <= 1.0 else "rejected"
        iterations = " ".join(str(r.iterations) for r in outcome.reports)
        out.write(f"step t={self.state.t:.17g} h={h:.17g} ode={err_ode:.17g} "
                  f"lam={err_lam:.17g} iterations {iterations} integrations "
                  f"{outcome.integrations} {verdict}\n")
        return err_ode, err_lam

    def traced_step(self, state, h, lam_predicted):
        try:
            return stepper_step(self, state, h, lam_predicted)
        except PassFailure as failure:
            out.write(f"step t={state.t:.17g} h={h:.17g} failed {failure.stage} "
                      f"row {failure.row}\n")
            raise

    integrator.IterativeRun._errors = traced_errors
    integrator.Stepper.step = traced_step
    integrator.IterativeRun._fire = traced_fire


def main(path: str, t_end: float) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        module = load_generated(compile_numpy(load_model(path), tmp))
    install_trace(sys.stdout)
    simulate(module, t_end=t_end)


if __name__ == "__main__":
    main(sys.argv[1], float(sys.argv[2]))
