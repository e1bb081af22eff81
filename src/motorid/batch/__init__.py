"""A class's experiments at once: ``motorid batch`` on joblib (this machine) or Dask (a cluster).

- :func:`run_batch` — find every experiment under the roots, identify each (in parallel,
  skipping those already done with the same inputs and settings), write each one's model
  JSON and report, and the class summary ``summary.csv`` / ``summary.html``.
- :class:`BatchSettings` — the identify options and what to write (the resume hash covers it).
- :func:`discover_experiments`, :class:`ExperimentSpec` — what counts as an experiment folder
  (``ALLnnnn`` triples, folders of captures, plain CSV logs; ``experiment.toml`` /
  ``manifest.csv`` naming the roles).
- :func:`parallel_map` — the engine: joblib ``loky`` processes with one BLAS thread each and
  a seed per task, or the same call on a ``distributed.Client`` (``scheduler=``).
- :func:`robust_z`, :data:`OUTLIER_Z` — the modified z-score that flags outliers.

The package sits above the front door (it calls :func:`motorid.read_experiment` and
:func:`motorid.identify`) and below the command line.
"""

from __future__ import annotations

from motorid.batch.discover import ExperimentSpec, discover_experiments
from motorid.batch.engine import parallel_map, task_seed
from motorid.batch.run import BatchResult, run_batch
from motorid.batch.summary import OUTLIER_Z, SummaryRow, robust_z
from motorid.batch.task import BatchSettings, ExperimentOutcome

__all__ = [
    "OUTLIER_Z",
    "BatchResult",
    "BatchSettings",
    "ExperimentOutcome",
    "ExperimentSpec",
    "SummaryRow",
    "discover_experiments",
    "parallel_map",
    "robust_z",
    "run_batch",
    "task_seed",
]
