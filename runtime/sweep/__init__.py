"""depsim.runtime.sweep: parameter studies (grids and Monte Carlo) of a generated module.

    from depsim.runtime.sweep import sweep, summarize, plot_study
    ds = sweep("build/intelsat5.py", samples=["h2.friction=normal(0.64, 0.05)"],
               runs=1000, seed=1, out="study.nc")
    print(summarize(ds, limits={"peak.h1.torque": 8.5})); plot_study(ds, "study.png")

Pieces: `make_design` (spec strings -> run matrix), `Study` + `run_study` (execution on a local
process pool, in-process, or Dask; checkpoint and resume; NetCDF), `summarize`, `plot_study`,
`probability` (k of n runs with its Clopper-Pearson interval).
Works on generated module files only: no sympy, no depsim.dsl / depsim.codegen.
"""

from .backends import StudyError, default_workers
from .local import LocalStudy, local_study
from .metrics import Metric
from .plot import plot_study, study_figure
from .probability import Probability, exceedance, not_deployed, probability
from .progress import StudyProgress
from .spec import Design, Distribution, GridAxis, SweepSpecError, make_design, parse_grid, \
    parse_sample
from .storage import ENGINE, CheckpointError, open_study, partial_path
from .study import Study, run_study, sweep
from .summary import drivers, metric_table, summarize
from .worker import ModuleRef, load_module

__all__ = [
    "sweep", "Study", "run_study", "make_design", "Design", "GridAxis", "Distribution",
    "parse_grid", "parse_sample", "SweepSpecError", "StudyError", "CheckpointError",
    "StudyProgress", "Metric", "summarize", "metric_table", "drivers", "plot_study",
    "study_figure", "Probability", "probability", "not_deployed", "exceedance",
    "open_study", "partial_path", "load_module", "ModuleRef", "ENGINE", "default_workers",
    "LocalStudy", "local_study",
]
