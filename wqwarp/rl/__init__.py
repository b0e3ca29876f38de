"""Residual RL: config and presets, reward and observation registries, commands and events, the rsl-rl env,
estimator, gait selection, the PPO algorithm with its extensions, runner, progress log and export."""
