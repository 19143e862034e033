"""Evaluation of runs: structural metrics (``structural``) and the metrics against ground truth."""
