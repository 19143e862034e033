"""Evaluation of runs: structural metrics (``structural``) and the metrics against ground truth
(``ground_truth``); ``evaluate_run`` writes RUN/eval/metrics.json and report.md."""

from rescene_core.evaluation.run import evaluate_run

__all__ = ["evaluate_run"]
