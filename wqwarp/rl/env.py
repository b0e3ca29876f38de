"""The residual-RL environment: an rsl-rl ``VecEnv`` of wheeled Go1 robots on the nominal gait.

Lifecycle of :meth:`WheeledGo1Env.step`: actions -> (nominal gait + residuals -> IK -> targets) -> physics
(decimation x (actuation, power, MuJoCo)) -> rewards (``wqwarp.kernels.rewards``) -> terminations, gait-selector
bookkeeping and resets -> commands and pushes -> estimator -> observations -> gait selection on o_t
(``wqwarp.rl.gait_selection``). Nothing learns inside ``step``: with ``collect_training_data`` set the env only stores
training data for the estimator and the power predictor, which the runner fits. Simulator arrays cross to torch
zero-copy.

Actor observation o_t (paper, "Observation Space of the Actor"), in this order (:func:`observation_layout`):
    base_ang_vel (3)  base angular velocity, base frame, x0.25 [rad/s]
    gravity (3)       projected gravity, base frame [-]
    leg_pos (12)      leg joint positions minus the default pose [rad]
    joint_vel (16)    all 16 joint velocities x0.05 [rad/s]
    gait (18)         p_t: sin(2 pi phi) (4), cos(2 pi phi) (4), phase residuals (4), f [Hz], DF_swing, nominal
                      wheel speeds x0.05 (4) [rad/s]; zeros without a nominal gait
    estimate (3)      z_t: estimated v_x, v_y x2 [m/s] and base height [m]
    command (3)       v_x, v_y x2 [m/s], w_z x0.25 [rad/s]
    prev_action (A), prev2_action (A)   a_{t-1}, a_{t-2}; A = 20 (16 for the baseline)
The paper states previous actions of dimension 22 while its action list sums to 20; we use the action size.
Noise (uniform, ``ObservationConfig``) is added to the sensor part. Critic observation = actor observation plus
privileged x_t: true base velocity (3, base frame), height, friction, restitution, added mass, wheel contact forces
(4, /100 N), the current push (2) [m/s], running gait one-hot (3; zeros without a nominal gait).
"""

from __future__ import annotations

import math

import numpy as np
import torch
import warp as wp
from rsl_rl.env import VecEnv
from tensordict import TensorDict

from wqwarp.control.gaits import GAIT_LIBRARY, GAIT_NAMES, gait_index
from wqwarp.control.nominal import NominalGait
from wqwarp.kernels.actions import joint_offset_targets, residual_targets
from wqwarp.kernels.rewards import compute_rewards
from wqwarp.rl.config import REWARD_TERMS, EnvConfig
from wqwarp.rl.estimator import EstimatorTrainer, StateEstimator
from wqwarp.rl.gait_selection import make_gait_selector
from wqwarp.robot import constants as C
from wqwarp.sim.simulator import Simulator

PRIVILEGED_DIM = 3 + 1 + 1 + 1 + 1 + 4 + 2 + len(GAIT_LIBRARY)


def observation_layout(num_actions: int) -> list[tuple[str, int]]:
    """(name, size) of each part of the actor observation, in order."""
    return [
        ("base_ang_vel", 3), ("gravity", 3), ("leg_pos", 12), ("joint_vel", 16), ("gait", 18), ("estimate", 3),
        ("command", 3), ("prev_action", num_actions), ("prev2_action", num_actions),
    ]  # fmt: skip


def decode_observation(obs: torch.Tensor, num_actions: int) -> dict[str, torch.Tensor]:
    """Split actor observations (..., D) into their named parts (inverse of the layout)."""
    out, i = {}, 0
    for name, n in observation_layout(num_actions):
        out[name] = obs[..., i : i + n]
        i += n
    if i != obs.shape[-1]:
        raise ValueError(f"observation has {obs.shape[-1]} columns, the layout for {num_actions} actions has {i}")
    return out


def quat_rotate_inv(q: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """Rotate world vectors v (N, 3) into the frame of quaternions q (N, 4) in xyzw order."""
    xyz, w = q[:, :3], q[:, 3:4]
    t = 2.0 * torch.cross(xyz, v, dim=-1)
    return v - w * t + torch.cross(xyz, t, dim=-1)


class WheeledGo1Env(VecEnv):
    """rsl-rl vectorized environment of the paper's residual-RL wheeled Go1 (see the module docstring)."""

    def __init__(self, cfg: EnvConfig):
        self.cfg = cfg
        self.sim = Simulator(cfg.sim)
        sim = self.sim
        self.num_envs = sim.num_envs
        self.device = "cpu" if sim.device.is_cpu else str(sim.device)
        dev = self.device
        n = self.num_envs
        self.dt = sim.policy_dt
        self.max_episode_length = int(math.ceil(cfg.episode_length_s / self.dt))
        self.episode_length_buf = torch.zeros(n, dtype=torch.long, device=dev)
        self.gen = torch.Generator(device=dev)
        self.gen.manual_seed(cfg.seed)

        a = cfg.action
        self.residual_mode = a.use_nominal_legs
        if cfg.gait.selection == "none" and a.use_nominal_legs:
            raise ValueError("action.use_nominal_legs needs a nominal gait (gait.selection != 'none')")
        if cfg.gait.selection not in ("none", "fixed", "predictive"):
            raise ValueError(f"unknown gait.selection {cfg.gait.selection!r}; choose none, fixed or predictive")
        self.num_actions = 20 if self.residual_mode else 16
        self.nominal = None
        start_gait = gait_index(cfg.gait.fixed_gait)
        if cfg.gait.selection != "none":
            self.nominal = NominalGait(n, sim.device, body_height=cfg.gait.body_height,
                                       swing_height=cfg.gait.swing_height,
                                       swing_x_amplitude=cfg.gait.swing_x_amplitude,
                                       phase_mode=cfg.action.phase_residual_mode)  # fmt: skip
            wp.to_torch(self.nominal.gait_id)[:] = start_gait
            self.nominal.reset(np.arange(n))

        # Zero-copy torch views of the simulator.
        self.tv = sim.torch_views()
        self.actions_wp = wp.zeros((n, self.num_actions), dtype=wp.float32, device=sim.device)
        self.actions = wp.to_torch(self.actions_wp)
        self.prev_actions = torch.zeros_like(self.actions)
        self.prev2_actions = torch.zeros_like(self.actions)
        self.prev_actions_wp = wp.from_torch(self.prev_actions)
        self.prev2_actions_wp = wp.from_torch(self.prev2_actions)
        self.commands_wp = self.nominal.command if self.nominal else wp.zeros((n, 3), dtype=wp.float32,
                                                                              device=sim.device)  # fmt: skip
        self.commands = wp.to_torch(self.commands_wp)
        self.prev_qd_wp = wp.zeros((n, 16), dtype=wp.float32, device=sim.device)
        self.foot_residual_wp = wp.zeros((n, 4), dtype=wp.vec3, device=sim.device)
        self.default_leg_q = torch.tensor(C.DEFAULT_JOINT_POS[:12], dtype=torch.float32, device=dev)
        self.default_leg_q_wp = wp.from_torch(self.default_leg_q.clone())
        spawn = torch.tensor(sim._default_q, dtype=torch.float32, device=dev)
        spawn[2] += 0.02  # spawn slightly above the ground
        self._spawn_q = spawn[None, :]
        self._leg_coords = torch.tensor(sim.layout.actuated_coord[:12], dtype=torch.long, device=dev)

        # Rewards.
        self.reward_weights = wp.array(np.asarray(cfg.reward.weights(), np.float32), dtype=wp.float32,
                                       device=sim.device)  # fmt: skip
        self.reward_wp = wp.zeros(n, dtype=wp.float32, device=sim.device)
        self.reward_terms_wp = wp.zeros((n, len(REWARD_TERMS)), dtype=wp.float32, device=sim.device)
        self.episode_sums_wp = wp.zeros((n, len(REWARD_TERMS)), dtype=wp.float32, device=sim.device)
        self.reward_buf = wp.to_torch(self.reward_wp)
        self.episode_sums = wp.to_torch(self.episode_sums_wp)
        self.active_terms = [k for k, w in zip(REWARD_TERMS, cfg.reward.weights(), strict=True) if w != 0.0]

        # Domain randomisation (fixed per robot for the run) and pushes.
        dr = cfg.domain_rand
        nominal_mu = torch.full((n,), float(dr.nominal_friction), device=dev)
        self.friction = self._uniform(dr.friction_range, (n,)) if dr.enabled else nominal_mu
        self.restitution = self._uniform(dr.restitution_range, (n,)) if dr.enabled else torch.zeros(n, device=dev)
        self.added_mass = self._uniform(dr.added_mass_range, (n,)) if dr.enabled else torch.zeros(n, device=dev)
        sim.set_dynamics(self.friction.cpu().numpy(), self.restitution.cpu().numpy(), self.added_mass.cpu().numpy())
        if dr.enabled:
            self.tv["motor_strength"][:] = self._uniform(dr.motor_strength_range, (n, 16))
        self.push_vel = torch.zeros(n, 2, device=dev)
        self.push_interval_steps = int(round(dr.push_interval / self.dt)) if dr.enabled and dr.push_interval > 0 else 0
        self.common_step_counter = 0
        self.resample_steps = max(1, int(round(cfg.commands.resampling_time / self.dt)))

        # Estimator over the last H proprioceptive observations (o_t without z_t).
        self.obs_layout = observation_layout(self.num_actions)
        self.num_obs = sum(k for _, k in self.obs_layout)
        self.proprio_dim = self.num_obs - 3
        H = cfg.obs.history_length
        self.history = torch.zeros(n, H, self.proprio_dim, device=dev)
        self.estimator = StateEstimator(H * self.proprio_dim, tuple(cfg.estimator.hidden_dims)).to(dev)
        self.estimator_trainer = EstimatorTrainer(self.estimator, cfg.estimator.learning_rate, cfg.estimator.epochs,
                                                  cfg.estimator.batch_size)  # fmt: skip
        self.estimate = torch.zeros(n, 3, device=dev)
        o = cfg.obs
        self._down = torch.tensor([[0.0, 0.0, -1.0]], device=dev)
        self._command_scale = torch.tensor([o.lin_vel_scale, o.lin_vel_scale, o.ang_vel_scale], device=dev)
        self._estimate_scale = torch.tensor([o.lin_vel_scale, o.lin_vel_scale, 1.0], device=dev)
        # Gait selection: the selector writes the requested gait into nominal.gait_id (its only home).
        requested = wp.to_torch(self.nominal.gait_id) if self.nominal is not None else None
        self.gait_selector = make_gait_selector(cfg, requested, GAIT_NAMES, start_gait, self.dt, self.num_obs)
        self._collect = False
        self.unstable_count = torch.zeros((), dtype=torch.long, device=dev)
        """Robot-steps whose simulation diverged since construction (terminated and reset, ``sim.unstable``)."""
        self.held_commands: torch.Tensor | None = None
        """Commands held by :meth:`hold_commands` (evaluation), or None for random commands."""
        self.extras: dict = {}
        self._reset_envs(torch.arange(n, device=dev))
        self._obs = self._observe()

    # --- helpers --------------------------------------------------------------------------------------------------
    def _uniform(self, rng: tuple[float, float], shape) -> torch.Tensor:
        lo, hi = rng
        return lo + (hi - lo) * torch.rand(shape, generator=self.gen, device=self.device)

    def base_state(self) -> dict[str, torch.Tensor]:
        """True base quantities: quaternion (xyzw), linear / angular velocity in the base frame, height [m]."""
        q = self.tv["joint_q"][:, 3:7]
        qd = self.tv["joint_qd"]
        return {
            "quat": q,
            "lin_vel": quat_rotate_inv(q, qd[:, 0:3]),
            "ang_vel": quat_rotate_inv(q, qd[:, 3:6]),
            "height": self.tv["joint_q"][:, 2],
            "gravity": quat_rotate_inv(q, self._down.expand(len(q), 3)),
        }

    # --- rsl-rl interface -----------------------------------------------------------------------------------------
    def get_observations(self) -> TensorDict:
        return self._obs

    @property
    def collect_training_data(self) -> bool:
        """True while a training runner collects rollouts: the env stores (history, true state) pairs for the
        estimator and labelled power windows for the predictor, and the predictive selector samples at the
        schedule's temperature. False (the default: evaluation, playback, export) stores nothing, so nothing can
        learn, and the selector uses ``predictor.evaluation_selection``. The learning itself happens in the runner
        (``wqwarp.rl.runner.WqRunner``), never in :meth:`step`."""
        return self._collect

    @collect_training_data.setter
    def collect_training_data(self, value: bool) -> None:
        self._collect = bool(value)
        self.gait_selector.set_training(self._collect)
        if not self._collect:
            self.estimator_trainer.clear()

    def active_gait(self) -> torch.Tensor:
        """Gait in effect per robot (N,) long (zeros without a nominal gait)."""
        if self.nominal is None:
            return torch.zeros(self.num_envs, dtype=torch.long, device=self.device)
        return wp.to_torch(self.nominal.active_gait_id).long()

    def requested_gait(self) -> torch.Tensor:
        """Gait requested per robot (N,) long: a view of ``nominal.gait_id`` (zeros without a nominal gait)."""
        if self.nominal is None:
            return torch.zeros(self.num_envs, dtype=torch.long, device=self.device)
        return wp.to_torch(self.nominal.gait_id).long()

    def step(self, actions: torch.Tensor):
        cfg, sim = self.cfg, self.sim
        a = torch.clamp(actions.to(self.device), -cfg.action.clip_actions, cfg.action.clip_actions)
        self.actions[:] = a
        self._apply_actions()
        wp.copy(self.prev_qd_wp, sim.actuated_qd)
        sim.step()
        self.episode_length_buf += 1
        self.common_step_counter += 1
        rewards = self._compute_rewards()
        # A robot whose simulation diverged (sim.unstable) is terminated and reset; nothing it produced in this step
        # (reward, power, metrics, episode sums) reaches the learners or the logs.
        unstable = self.tv["unstable"] > 0
        self.last_unstable = unstable
        """Robots whose simulation diverged in the last step (terminated and reset)."""
        self._quarantine(unstable, rewards)
        fell = (self.tv["body_collision"][:, 0] > 0) & ~unstable
        died = fell | unstable
        time_out = (self.episode_length_buf >= self.max_episode_length) & ~unstable
        dones = died | time_out
        self.gait_selector.record_step(self.tv["p_cost"], self.active_gait(), self.commands, dones, fell)
        self.prev2_actions[:] = self.prev_actions
        self.prev_actions[:] = self.actions
        # Metrics see the state before resets; the observations below re-read it after resets and pushes.
        self.extras = {"time_outs": time_out.clone(), "log": self._step_metrics(self.base_state(), ~unstable)}
        done_ids = dones.nonzero(as_tuple=False).flatten()
        if len(done_ids):
            self.extras["log"].update(self._episode_log(done_ids, unstable))
            self._reset_envs(done_ids)
        resample = (self.episode_length_buf % self.resample_steps == 0).nonzero(as_tuple=False).flatten()
        if len(resample):
            self._resample_commands(resample)
        if self.push_interval_steps and self.common_step_counter % self.push_interval_steps == 0:
            self._push_robots()
        self._obs = self._observe()
        return self._obs, rewards.clone(), dones.to(torch.long), self.extras

    def reset(self) -> TensorDict:
        self._reset_envs(torch.arange(self.num_envs, device=self.device))
        self._obs = self._observe()
        return self._obs

    def refresh_after_load(self) -> None:
        """Observe again, with every robot due for a gait selection, after networks were loaded into the env: the
        estimate in o_t and the gait each robot is reset into would otherwise come from the networks the env was
        built with (random initialisation), so the first seconds of a rollout would depend on torch's global RNG."""
        due = getattr(self.gait_selector, "due", None)
        if due is not None:
            due[:] = True
        self._obs = self._observe()

    def _observe(self) -> TensorDict:
        """o_t and the critic's observation, then the gait selection that reads o_t."""
        obs = self._compute_observations()
        self.gait_selector.select(obs["policy"], self.active_gait())
        return obs

    # --- actions -------------------------------------------------------------------------------------------------
    def _apply_actions(self) -> None:
        cfg, sim, a = self.cfg.action, self.sim, self.actions
        if self.residual_mode:
            ng = self.nominal
            wp.to_torch(ng.phase_residual)[:] = torch.clamp(cfg.phase_scale * a[:, :4], -cfg.phase_clip, cfg.phase_clip)
            ng.step(sim.actuated_q[:, :12], sim.wheel_contact, self.dt)
            wp.launch(residual_targets, dim=(self.num_envs, 4),
                      inputs=[self.actions_wp, ng.foot_target, ng.wheel_velocity, int(cfg.use_nominal_wheels),
                              cfg.foot_scale, cfg.foot_clip, cfg.wheel_scale, cfg.wheel_clip],
                      outputs=[self.foot_residual_wp, sim.leg_q_target, sim.wheel_qd_target],
                      device=sim.device)  # fmt: skip
        else:
            wp.launch(joint_offset_targets, dim=self.num_envs,
                      inputs=[self.actions_wp, self.default_leg_q_wp, cfg.joint_scale, cfg.wheel_scale, cfg.wheel_clip],
                      outputs=[sim.leg_q_target, sim.wheel_qd_target], device=sim.device)  # fmt: skip

    # --- rewards and logs ----------------------------------------------------------------------------------------
    def _compute_rewards(self) -> torch.Tensor:
        sim = self.sim
        wp.launch(compute_rewards, dim=self.num_envs,
                  inputs=[sim.joint_q, sim.joint_qd, self.commands_wp, self.actions_wp, self.prev_actions_wp,
                          self.prev2_actions_wp, sim.actuated_qd, self.prev_qd_wp, sim.torque_sq, sim.power_sq,
                          sim.body_collision, self.reward_weights, self.cfg.reward.tracking_sigma, self.dt],
                  outputs=[self.reward_wp, self.reward_terms_wp, self.episode_sums_wp],
                  device=sim.device)  # fmt: skip
        return self.reward_buf

    def _step_metrics(self, b: dict, valid: torch.Tensor) -> dict:
        """Means over the robots whose step is ``valid`` (not diverged)."""
        count = valid.float().sum().clamp(min=1.0)
        mean = lambda x: torch.where(valid, x, torch.zeros_like(x)).sum() / count  # noqa: E731
        err = torch.abs(b["lin_vel"][:, :2] - self.commands[:, :2])
        werr = torch.abs(b["ang_vel"][:, 2] - self.commands[:, 2])
        out = {"Metrics/vx_error": mean(err[:, 0]), "Metrics/vy_error": mean(err[:, 1]), "Metrics/wz_error": mean(werr)}
        for k in ("p_cost", "p_cost_legs", "p_cost_wheels", "p_mech_legs", "p_mech_wheels", "p_joule_legs",
                  "p_joule_wheels"):  # fmt: skip
            out[f"Metrics/{k}"] = mean(self.tv[k])
        return out

    def _episode_log(self, ids: torch.Tensor, unstable: torch.Tensor) -> dict:
        """Per-term episode rewards per second over the ended episodes that did not diverge, and the shares of
        ended episodes that ended by a base contact or by a diverged simulation."""
        bad = unstable[ids]
        ok = (~bad).float()  # masked means: no boolean selection (a host synchronisation on CUDA)
        seconds = torch.clamp(self.episode_length_buf[ids].float() * self.dt, min=self.dt)
        count = ok.sum().clamp(min=1.0)
        log = {}
        for k, name in enumerate(REWARD_TERMS):
            if name in self.active_terms:
                log[f"Episode_Reward/{name}"] = torch.sum(self.episode_sums[ids, k] / seconds * ok) / count
        early = self.episode_length_buf[ids] < self.max_episode_length
        log["Episode_Termination/base_contact"] = torch.mean((early & ~bad).float())
        log["Episode_Termination/unstable"] = torch.mean(bad.float())
        return log

    def _quarantine(self, unstable: torch.Tensor, rewards: torch.Tensor) -> None:
        """Keep what diverged robots produced in this step out of rewards, power, metrics and episode sums (masked
        writes: no host synchronisation on CUDA)."""
        self.unstable_count += unstable.sum()
        rewards.masked_fill_(unstable, 0.0)
        for k in ("p_cost", "p_mech", "p_joule", "p_cost_legs", "p_cost_wheels", "p_mech_legs", "p_mech_wheels",
                  "p_joule_legs", "p_joule_wheels", "torque_sq", "power_sq"):  # fmt: skip
            self.tv[k].masked_fill_(unstable, 0.0)
        self.episode_sums.masked_fill_(unstable[:, None], 0.0)

    # --- resets, commands, pushes --------------------------------------------------------------------------------
    def _reset_envs(self, ids: torch.Tensor) -> None:
        """Reset robots ``ids`` (a tensor on the env's device): spawn pose with random yaw and leg angles, written
        by kernels on the device (no host copy of the state)."""
        k = len(ids)
        sim = self.sim
        q = self._spawn_q.expand(k, -1).clone()
        yaw = self._uniform((-math.pi, math.pi), (k,))
        q[:, 5], q[:, 6] = torch.sin(yaw / 2), torch.cos(yaw / 2)
        q[:, self._leg_coords] += self._uniform((-0.05, 0.05), (k, 12))
        ids32 = ids.to(torch.int32)
        qd = torch.zeros(k, sim.layout.dofs_per_world, device=self.device)
        self._reset_inputs = (ids32, q, qd)  # alive until the next reset: the device may still read them
        sim.reset(ids32, q, qd)
        if self.nominal is not None:
            self.nominal.reset(ids32)
        self.gait_selector.on_reset(ids)
        self.actions[ids] = 0.0
        self.prev_actions[ids] = 0.0
        self.prev2_actions[ids] = 0.0
        self.episode_sums[ids] = 0.0
        self.episode_length_buf[ids] = 0
        self.history[ids] = 0.0
        self.push_vel[ids] = 0.0
        self._resample_commands(ids)
        wp.copy(self.prev_qd_wp, self.sim.actuated_qd)

    def hold_commands(self, commands: torch.Tensor | None) -> None:
        """Hold the commands (N, 3) (v_x, v_y, w_z) in the base frame from now on: resets and the periodic
        resampling write these instead of random ones, so no observation ever carries another command (evaluation).
        ``None`` returns to random commands."""
        if commands is None:
            self.held_commands = None
            return
        self.held_commands = torch.as_tensor(commands, dtype=torch.float32, device=self.device).clone()
        self.commands[:] = self.held_commands

    def _resample_commands(self, ids: torch.Tensor) -> None:
        if self.held_commands is not None:
            self.commands[ids] = self.held_commands[ids]
            return
        c = self.cfg.commands
        k = len(ids)
        cmd = torch.stack([self._uniform(c.vx_range, (k,)), self._uniform(c.vy_range, (k,)),
                           self._uniform(c.wz_range, (k,))], dim=1)  # fmt: skip
        u = torch.rand(k, generator=self.gen, device=self.device)
        single = u < c.single_axis_prob
        axis = torch.randint(0, 3, (k,), generator=self.gen, device=self.device)
        keep = torch.nn.functional.one_hot(axis, 3).float()
        cmd = torch.where(single[:, None], cmd * keep, cmd)
        zero = (u >= c.single_axis_prob) & (u < c.single_axis_prob + c.zero_prob)
        cmd[zero] = 0.0
        self.commands[ids] = cmd

    def set_commands(self, commands: torch.Tensor) -> None:
        """Overwrite the commands (N, 3) (v_x, v_y, w_z) in the base frame, e.g. for evaluation."""
        self.commands[:] = commands.to(self.device)

    def set_command(self, commands) -> None:
        """:meth:`hold_commands` for a NumPy or torch (N, 3) array (``tools/export_usd.py``): held also across
        resets."""
        self.hold_commands(torch.as_tensor(commands, dtype=torch.float32))

    def _push_robots(self, max_vel: float | None = None) -> None:
        """Random velocity impulses up to ``max_vel`` [m/s] (default ``domain_rand.push_max_vel``) along the trunk's
        x and y axes."""
        m = self.cfg.domain_rand.push_max_vel if max_vel is None else max_vel
        n = self.num_envs
        dv = self._uniform((-m, m), (n, 2))
        self.push_vel[:] = dv
        # The impulse is along the trunk's x and y axes, added to the world-frame base velocity in place (a view of
        # Newton's state on the device); the physics is told which coordinates changed.
        quat = self.tv["joint_q"][:, 3:7]
        yaw = torch.atan2(2 * (quat[:, 3] * quat[:, 2] + quat[:, 0] * quat[:, 1]),
                          1 - 2 * (quat[:, 1] ** 2 + quat[:, 2] ** 2))  # fmt: skip
        c, s = torch.cos(yaw), torch.sin(yaw)
        qd = self.tv["joint_qd"]
        qd[:, 0] += c * dv[:, 0] - s * dv[:, 1]
        qd[:, 1] += s * dv[:, 0] + c * dv[:, 1]
        self.sim.state_written()

    # --- observations ---------------------------------------------------------------------------------------------
    def _gait_obs(self) -> torch.Tensor:
        n = self.num_envs
        if self.nominal is None:
            return torch.zeros(n, 18, device=self.device)
        ng = self.nominal
        phase = wp.to_torch(ng.phase)
        gid = wp.to_torch(ng.active_gait_id).long()
        freq = wp.to_torch(ng.arrays.frequency)[gid]
        df = wp.to_torch(ng.arrays.df_swing)[gid]
        vn = wp.to_torch(ng.wheel_velocity)
        if not self.cfg.action.use_nominal_wheels:
            vn = torch.zeros_like(vn)
        return torch.cat([torch.sin(2 * math.pi * phase), torch.cos(2 * math.pi * phase),
                          wp.to_torch(ng.phase_residual), freq[:, None], df[:, None],
                          vn * self.cfg.obs.wheel_speed_scale], dim=1)  # fmt: skip

    def _noise(self, shape, scale: float) -> torch.Tensor:
        if not self.cfg.obs.noise or scale == 0.0:
            return torch.zeros(shape, device=self.device)
        return (2.0 * torch.rand(shape, generator=self.gen, device=self.device) - 1.0) * scale

    def _compute_observations(self) -> TensorDict:
        o, n = self.cfg.obs, self.num_envs
        b = self.base_state()
        q = self.tv["actuated_q"]
        qd = self.tv["actuated_qd"]
        ang = (b["ang_vel"] + self._noise((n, 3), o.noise_ang_vel)) * o.ang_vel_scale
        grav = b["gravity"] + self._noise((n, 3), o.noise_gravity)
        leg = q[:, :12] - self.default_leg_q + self._noise((n, 12), o.noise_joint_pos)
        vel = (qd + self._noise((n, 16), o.noise_joint_vel)) * o.joint_vel_scale
        cmd = self.commands * self._command_scale
        proprio = torch.cat([ang, grav, leg, vel, self._gait_obs(), cmd, self.prev_actions, self.prev2_actions], 1)
        # History of proprioceptive observations -> estimator -> z_t.
        self.history = torch.roll(self.history, shifts=-1, dims=1)
        self.history[:, -1] = proprio
        true_z = torch.stack([b["lin_vel"][:, 0], b["lin_vel"][:, 1], b["height"]], 1)
        hist = self.history.reshape(n, -1)
        if self._collect:
            self.estimator_trainer.add(hist, true_z)
        if self.cfg.estimator.use_true_state:
            z = true_z
        else:
            with torch.no_grad():
                z = self.estimator(hist)
        self.estimate = z.detach()
        zs = z * self._estimate_scale
        split = 3 + 3 + 12 + 16 + 18
        actor = torch.cat([proprio[:, :split], zs, proprio[:, split:]], 1)
        gid = torch.nn.functional.one_hot(self.active_gait(), len(GAIT_LIBRARY)).float()
        if self.nominal is None:
            gid = torch.zeros_like(gid)
        priv = torch.cat([
            b["lin_vel"] * o.lin_vel_scale, b["height"][:, None], self.friction[:, None], self.restitution[:, None],
            self.added_mass[:, None], self.tv["wheel_force"] / 100.0, self.push_vel, gid,
        ], 1)  # fmt: skip
        return TensorDict({"policy": actor, "privileged": priv}, batch_size=[n], device=self.device)

    def close(self) -> None:
        pass
