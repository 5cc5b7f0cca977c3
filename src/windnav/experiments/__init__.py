"""Experiment harnesses: the task executor (serial / process / ray), sweeps, metrics."""

from windnav.experiments.executor import BACKENDS, TaskResult, run_tasks

__all__ = ["BACKENDS", "TaskResult", "run_tasks"]
