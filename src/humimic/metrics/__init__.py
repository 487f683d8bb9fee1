"""Scores against ground truth, and the end-of-run summary."""
