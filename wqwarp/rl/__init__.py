"""Residual RL: config and presets, the rsl-rl env, estimator, gait selection, runner and export."""
