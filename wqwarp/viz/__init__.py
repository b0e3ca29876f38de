"""Visualisation: time-sampled USD rollouts and offscreen videos (MuJoCo's renderer)."""
