"""depsim.runtime.sweep: parameter studies (grids and Monte Carlo) of a generated module.

    from depsim.runtime.sweep import sweep, summarize, plot_study
    ds = sweep("build/intelsat5.py", samples=["h2.friction=normal(0.64, 0.05)"],
               runs=1000, seed=1, out="study.nc")
    print(summarize(ds, limits={"peak.h1.torque": 8.5})); plot_study(ds, "study.png")

Pieces: `make_design` (spec strings -> run matrix), `Study` + `run_study` (execution on a local
process pool, in-process, or Dask; checkpoint and resume; NetCDF), `summarize`, `plot_study`,
`probability` (k of n runs with its Clopper-Pearson interval).
Works on generated module files only: no sympy, no depsim.dsl / depsim.codegen.
The names below are imported on first use, so a study's worker process, which imports
`depsim.runtime.sweep.worker`, loads that module and what it needs alone (not the pool, the
storage, the summary or the plot).
"""

from .. import lazy_exports

_EXPORTS = {
    "sweep": "study", "Study": "study", "run_study": "study", "make_design": "spec",
    "Design": "spec", "GridAxis": "spec", "Distribution": "spec", "parse_grid": "spec",
    "parse_sample": "spec", "SweepSpecError": "spec", "StudyError": "backends",
    "CheckpointError": "storage", "StudyProgress": "progress", "Metric": "metrics",
    "summarize": "summary", "metric_table": "summary", "drivers": "summary",
    "plot_study": "plot", "study_figure": "plot", "Probability": "probability",
    "probability": "probability", "not_deployed": "probability", "exceedance": "probability",
    "open_study": "storage", "partial_path": "storage", "load_module": "worker",
    "ModuleRef": "worker", "ENGINE": "storage", "default_workers": "backends",
    "LocalStudy": "local", "local_study": "local", "StudyTable": "table",
}

__all__ = sorted(_EXPORTS)
__getattr__ = lazy_exports(__name__, _EXPORTS, globals())
