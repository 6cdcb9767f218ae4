"""Metrics, semantic diff, baselines and the CI gate, reports, Rerun views and export."""
