"""Evaluation: the paper's measures, its experiments and the report."""

from handvar.evaluation.metrics import (
    mean_joint_error,
    r2_tilde,
    r2_tilde_acceleration,
    r2_tilde_joints,
)

__all__ = ["mean_joint_error", "r2_tilde", "r2_tilde_acceleration", "r2_tilde_joints"]
