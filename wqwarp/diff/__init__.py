"""The differentiable path: taped rollouts on Newton Featherstone and gradient-based gait tuning."""
