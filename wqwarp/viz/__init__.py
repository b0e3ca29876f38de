"""Visualisation: time-sampled USD rollouts."""
