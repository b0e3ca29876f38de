"""Evaluation: the paper's protocols, checkpoint loading, physics variants and the results report."""
