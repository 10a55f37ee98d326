"""Evaluation metrics for the tracker (and, later, the detector)."""
