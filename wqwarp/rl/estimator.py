"""MLP state estimator: z_t = (v_x, v_y, h) of the base from the last H proprioceptive observations.

Paper, "Estimator Module": an MLP trained by supervised learning in simulation estimates the planar base velocity
and the base height from the observation history O_t^H (H = 6). Here it is regressed on the rollouts the PPO runner
collects: the environment stores (history, true state) pairs every step while a training runner collects, and the
algorithm fits the MLP after each PPO update (``wqwarp.rl.algorithm.EstimatorLearner``), never the environment
itself.
"""

from __future__ import annotations

import torch
from torch import nn


def mlp(input_dim: int, hidden_dims: tuple[int, ...], output_dim: int) -> nn.Sequential:
    """Linear + ELU per hidden layer, then a linear output (the estimator's and the power predictor's network)."""
    layers: list[nn.Module] = []
    d = input_dim
    for h in hidden_dims:
        layers += [nn.Linear(d, h), nn.ELU()]
        d = h
    layers.append(nn.Linear(d, output_dim))
    return nn.Sequential(*layers)


class StateEstimator(nn.Module):
    """MLP from a flattened history (B, H * D) to (v_x [m/s], v_y [m/s], h [m])."""

    def __init__(self, input_dim: int, hidden_dims: tuple[int, ...] = (128, 64), output_dim: int = 3):
        super().__init__()
        self.net = mlp(input_dim, hidden_dims, output_dim)
        self.input_dim = input_dim

    def forward(self, history: torch.Tensor) -> torch.Tensor:
        return self.net(history)


class EstimatorTrainer:
    """Collects (history, target) pairs; :meth:`fit` (called by the algorithm after PPO's update) fits the estimator
    on them by MSE."""

    def __init__(self, estimator: StateEstimator, lr: float, epochs: int, batch_size: int):
        self.estimator = estimator
        self.optimizer = torch.optim.Adam(estimator.parameters(), lr=lr)
        self.epochs = epochs
        self.batch_size = batch_size
        self._inputs: list[torch.Tensor] = []
        self._targets: list[torch.Tensor] = []
        self.last_loss = float("nan")
        """Mean squared error of the last fit [(m/s)^2 and m^2 mixed]."""

    def add(self, history: torch.Tensor, target: torch.Tensor) -> None:
        self._inputs.append(history.detach().clone())
        self._targets.append(target.detach().clone())

    def clear(self) -> None:
        """Forget the pairs collected since the last fit."""
        self._inputs.clear()
        self._targets.clear()

    def fit(self) -> float:
        if not self._inputs:
            return self.last_loss
        x = torch.cat(self._inputs)
        y = torch.cat(self._targets)
        self._inputs.clear()
        self._targets.clear()
        total, count = torch.zeros((), device=x.device), 0
        with torch.inference_mode(False), torch.enable_grad():
            x, y = x.clone(), y.clone()  # leave inference mode (the runner collects under torch.inference_mode)
            for _ in range(self.epochs):
                perm = torch.randperm(x.shape[0], device=x.device)
                for s in range(0, x.shape[0], self.batch_size):
                    idx = perm[s : s + self.batch_size]
                    loss = torch.mean((self.estimator(x[idx]) - y[idx]) ** 2)
                    self.optimizer.zero_grad()
                    loss.backward()
                    self.optimizer.step()
                    total += loss.detach()
                    count += 1
        self.last_loss = float(total) / max(count, 1)  # one device -> host copy per fit
        return self.last_loss
