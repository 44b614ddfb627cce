"""Evaluation: the paper's measures, its experiments and the report.

The experiment and report modules pull in Dask, xarray and matplotlib; they are
imported on first use so that the measures stay light.
"""

from handvar.evaluation.metrics import (
    mean_joint_error,
    r2_tilde,
    r2_tilde_acceleration,
    r2_tilde_joints,
)

_LAZY = {
    "ExperimentConfig": "config",
    "PredictorSpec": "config",
    "run_trial": "trials",
    "run_experiment": "experiment",
    "open_store": "store",
    "read_config": "store",
    "write_report": "report",
    "evaluate_claims": "claims",
}

__all__ = ["mean_joint_error", "r2_tilde", "r2_tilde_acceleration", "r2_tilde_joints", *_LAZY]


def __getattr__(name: str):
    if name in _LAZY:
        import importlib

        module = importlib.import_module(f"handvar.evaluation.{_LAZY[name]}")
        return getattr(module, name)
    raise AttributeError(f"module 'handvar.evaluation' has no attribute {name!r}")
