"""The residual-RL environment: an rsl-rl ``VecEnv`` of wheeled Go1 robots on the nominal gait.

Lifecycle of :meth:`WheeledGo1Env.step`: actions -> (nominal gait + residuals -> IK -> targets) -> physics
(decimation x (actuation, power, MuJoCo)) -> rewards (``wqwarp.kernels.rewards``) -> terminations, gait-selector
bookkeeping and resets -> commands and pushes (``wqwarp.rl.commands``, ``wqwarp.rl.events``) -> estimator ->
observations -> gait selection on o_t (``wqwarp.rl.gait_selection``). Nothing learns inside ``step``: with
``collect_training_data`` set the env only stores training data for the estimator and the power predictor, which the
algorithm fits after PPO's update (``wqwarp.rl.algorithm.WqPPO``). Simulator arrays cross to torch zero-copy.

Observation terms (actor o_t with the estimate z_t, critic x_t, their mirrors) are the registry
``wqwarp.rl.observations``; reward terms the registry ``wqwarp.rl.rewards`` (kernel funcs in
``wqwarp.kernels.rewards``); the gait library is ``cfg.gait.library``.
"""

from __future__ import annotations

import math

import numpy as np
import torch
import warp as wp
from rsl_rl.env import VecEnv
from tensordict import TensorDict

from wqwarp.control.gaits import gait_index
from wqwarp.control.nominal import NominalGait
from wqwarp.kernels.actions import joint_offset_targets, residual_targets
from wqwarp.kernels.power import POWER_OUTPUTS, REPORTED_POWER
from wqwarp.kernels.rewards import RewardInputs, make_reward_kernel
from wqwarp.rl import events
from wqwarp.rl import observations as obs_terms
from wqwarp.rl.commands import sample_commands, uniform
from wqwarp.rl.config import POWER_OUTPUT, EnvConfig
from wqwarp.rl.estimator import EstimatorTrainer, StateEstimator
from wqwarp.rl.gait_selection import make_gait_selector, tracking_error
from wqwarp.rl.observations import ACTOR_TERMS, ESTIMATE, PRIVILEGED_TERMS
from wqwarp.rl.rewards import TERMS, RewardTerm, check_terms, soft_joint_limits
from wqwarp.robot import constants as C
from wqwarp.sim.simulator import Simulator
from wqwarp.utils.checked_config import require


class WheeledGo1Env(VecEnv):
    """rsl-rl vectorized environment of the paper's residual-RL wheeled Go1 (see the module docstring)."""

    def __init__(self, cfg: EnvConfig, reward_terms: tuple[RewardTerm, ...] = TERMS):
        """``reward_terms``: the reward registry (default ``TERMS``: Table II, then the terms beyond it at weight 0;
        a term defined outside the package is added here, its weight the field of ``cfg.reward`` of its name or else
        its default)."""
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
        cfg.validate()  # every section's checks, again after fields were set one by one
        self.num_actions = 20 if self.residual_mode else 16
        self.nominal = None
        self.gait_names = tuple(g.name for g in cfg.gait.library)
        """Names of the gait library ``cfg.gait.library`` in gait-id order."""
        self.num_gaits = len(self.gait_names)
        start_gait = gait_index(cfg.gait.fixed_gait, cfg.gait.library)
        if cfg.gait.selection != "none":
            self.nominal = NominalGait(
                n,
                sim.device,
                library=cfg.gait.library,
                body_height=cfg.gait.body_height,
                swing_height=cfg.gait.swing_height,
                swing_x_amplitude=cfg.gait.swing_x_amplitude,
                phase_mode=cfg.action.phase_residual_mode,
                lateral_gain=cfg.gait.lateral_gain,
                lateral_limit=cfg.gait.lateral_limit,
            )
            wp.to_torch(self.nominal.gait_id)[:] = start_gait
            self.nominal.reset(np.arange(n))

        # Zero-copy torch views of the simulator.
        self.tv = sim.torch_views()
        self.power_measured = self.tv[POWER_OUTPUT[cfg.power_measure]]
        """(N,) view of the simulator's power output that ``cfg.power_measure`` names: the predictor's labels read it
        [W] (the reward's power term reads ``cfg.reward_power_output``, the same unless ``reward.power_measure``
        names another)."""
        self.actions_wp = wp.zeros((n, self.num_actions), dtype=wp.float32, device=sim.device)
        self.actions = wp.to_torch(self.actions_wp)
        self.prev_actions = torch.zeros_like(self.actions)
        self.prev2_actions = torch.zeros_like(self.actions)
        self.prev_actions_wp = wp.from_torch(self.prev_actions)
        self.prev2_actions_wp = wp.from_torch(self.prev2_actions)
        self.commands_wp = (
            self.nominal.command if self.nominal else wp.zeros((n, 3), dtype=wp.float32, device=sim.device)
        )
        self.commands = wp.to_torch(self.commands_wp)
        self.prev_qd_wp = wp.zeros((n, 16), dtype=wp.float32, device=sim.device)
        self.foot_residual_wp = wp.zeros((n, 4), dtype=wp.vec3, device=sim.device)
        self.default_leg_q = torch.tensor(C.DEFAULT_JOINT_POS[:12], dtype=torch.float32, device=dev)
        self.default_leg_q_wp = wp.from_torch(self.default_leg_q.clone())
        spawn = torch.tensor(sim._default_q, dtype=torch.float32, device=dev)
        spawn[2] += 0.02  # spawn slightly above the ground
        self._spawn_q = spawn[None, :]
        self._leg_coords = torch.tensor(sim.layout.actuated_coord[:12], dtype=torch.long, device=dev)

        # Rewards: one kernel column per registered term.
        check_terms(reward_terms)
        self.reward_names = tuple(t.name for t in reward_terms)
        """Reward term names in the order of the kernel's columns (``reward_terms_wp``, ``episode_sums``)."""
        weights = cfg.reward.weights(reward_terms)
        unknown = sorted(set(cfg.reward.ramp_terms) - set(self.reward_names))
        require(
            not unknown,
            "RewardConfig.ramp_terms",
            f"names no reward term: {', '.join(unknown)} (terms: {', '.join(self.reward_names)})",
        )
        self.full_reward_weights = np.asarray(weights, np.float32)
        """w_k of each term at full weight (what evaluation and a policy outside training see)."""
        self.ramped = np.array([n in cfg.reward.ramp_terms for n in self.reward_names])
        """Terms whose weights the training ramps in (``RewardConfig.ramp_terms``)."""
        self.reward_ramp_scale = 1.0
        """Factor on the ramped terms' weights now (:meth:`set_iteration`; 1 until training sets an iteration)."""
        self.ramp_gated = bool(self.ramped.any()) and cfg.reward.ramp_gate_vy_error > 0.0
        """The ramp waits for the lateral skill (``RewardConfig.ramp_gate_vy_error``)."""
        self.gate_error = torch.zeros(2, device=self.device)
        """Sum of the steps' Metrics/vy_error and their count since :meth:`take_gate_error` (a tensor: no host sync
        per step)."""
        self.reward_kernel = make_reward_kernel(tuple(t.resolve() for t in reward_terms))
        self.reward_weights = wp.array(self.full_reward_weights, dtype=wp.float32, device=sim.device)
        self.reward_wp = wp.zeros(n, dtype=wp.float32, device=sim.device)
        self.reward_terms_wp = wp.zeros((n, len(reward_terms)), dtype=wp.float32, device=sim.device)
        self.episode_sums_wp = wp.zeros((n, len(reward_terms)), dtype=wp.float32, device=sim.device)
        self.reward_buf = wp.to_torch(self.reward_wp)
        self.episode_sums = wp.to_torch(self.episode_sums_wp)
        self.active_terms = [k for k, w in zip(self.reward_names, weights, strict=True) if w != 0.0]
        self.joint_soft_limits_wp = tuple(
            wp.array(b.astype(np.float32), dtype=wp.float32, device=sim.device)
            for b in soft_joint_limits(cfg.reward.soft_joint_limit)
        )
        self.reward_inputs = self._reward_inputs()

        # Domain randomisation (fixed per robot for the run) and pushes.
        dr = cfg.domain_rand
        dyn = events.sample_dynamics(dr, n, self.gen, dev)
        self.friction, self.restitution, self.added_mass = dyn["friction"], dyn["restitution"], dyn["added_mass"]
        sim.set_dynamics(self.friction.cpu().numpy(), self.restitution.cpu().numpy(), self.added_mass.cpu().numpy())
        if "motor_strength" in dyn:
            self.tv["motor_strength"][:] = dyn["motor_strength"]
        self.push_vel = torch.zeros(n, 2, device=dev)
        self.push_interval_steps = int(round(dr.push_interval / self.dt)) if dr.enabled and dr.push_interval > 0 else 0
        self.common_step_counter = 0
        self.resample_steps = max(1, int(round(cfg.commands.resampling_time / self.dt)))

        # Observation layouts and mirrors from the registry; the estimator reads the last H proprioceptive
        # observations (o_t without z_t).
        dims = obs_terms.Dims(self.num_actions, self.num_gaits)
        self.obs_layout = obs_terms.layout(ACTOR_TERMS, dims)
        """(name, size) of each term of the actor observation o_t, in column order."""
        self.privileged_layout = obs_terms.layout(PRIVILEGED_TERMS, dims)
        """(name, size) of each term of the privileged x_t (critic: o_t then x_t)."""
        self.num_obs = sum(k for _, k in self.obs_layout)
        self.privileged_dim = sum(k for _, k in self.privileged_layout)
        self.estimate_index = obs_terms.estimate_index(dims)
        """Column of o_t where z_t (3) is inserted into the proprioceptive observation."""
        self.proprio_dim = self.num_obs - dict(self.obs_layout)[ESTIMATE]
        self._proprio_terms = tuple(t for t in ACTOR_TERMS if t.name != ESTIMATE)
        self.obs_mirror = obs_terms.mirror_matrix(ACTOR_TERMS, dims, dev)
        """(perm, signs) of the left-right mirror of o_t (``wqwarp.rl.observations``)."""
        self.privileged_mirror = obs_terms.mirror_matrix(PRIVILEGED_TERMS, dims, dev)
        self.action_mirror = obs_terms.mirror_tensors(obs_terms.action_mirror(self.num_actions), dev)
        self.action_groups = obs_terms.action_groups(self.num_actions)
        """Columns of each action group (phase, foot, wheel; joint, wheel for the baseline)."""
        H = cfg.obs.history_length
        self.history = torch.zeros(n, H, self.proprio_dim, device=dev)
        self.estimator = StateEstimator(H * self.proprio_dim, tuple(cfg.estimator.hidden_dims)).to(dev)
        self.estimator_trainer = EstimatorTrainer(
            self.estimator, cfg.estimator.learning_rate, cfg.estimator.epochs, cfg.estimator.batch_size
        )
        self.estimate = torch.zeros(n, 3, device=dev)
        o = cfg.obs
        self.command_scale = torch.tensor([o.lin_vel_scale, o.lin_vel_scale, o.ang_vel_scale], device=dev)
        self.estimate_scale = torch.tensor([o.lin_vel_scale, o.lin_vel_scale, 1.0], device=dev)
        """Scale of z_t = (v_x, v_y, h) in o_t (velocities as the command, the height as is)."""
        # Gait selection: the selector writes the requested gait into nominal.gait_id (its only home).
        requested = wp.to_torch(self.nominal.gait_id) if self.nominal is not None else None
        self.gait_selector = make_gait_selector(cfg, requested, self.gait_names, start_gait, self.dt, self.num_obs)
        self._collect = False
        self.unstable_count = torch.zeros((), dtype=torch.long, device=dev)
        """Robot-steps whose simulation diverged since construction (terminated and reset, ``sim.unstable``)."""
        self.held_commands: torch.Tensor | None = None
        """Commands held by :meth:`hold_commands` (evaluation), or None for random commands."""
        self.extras: dict = {}
        self._reset_envs(torch.arange(n, device=dev))
        self._obs = self._observe()
        got = (self._obs["policy"].shape[1], self._obs["privileged"].shape[1])
        if got != (self.num_obs, self.privileged_dim):
            raise ValueError(
                f"observation terms computed {got} columns, their layouts declare "
                f"{(self.num_obs, self.privileged_dim)} (wqwarp.rl.observations)"
            )

    # --- helpers --------------------------------------------------------------------------------------------------
    def _uniform(self, rng: tuple[float, float], shape) -> torch.Tensor:
        return uniform(self.gen, rng, shape, self.device)

    def base_state(self) -> dict[str, torch.Tensor]:
        """True base quantities (views of the simulator's base frame, ``kernels.state.compute_base_frame``):
        quaternion (xyzw), linear [m/s] / angular [rad/s] velocity and projected gravity in the base frame, height
        [m], yaw [rad]."""
        tv = self.tv
        return {
            "quat": tv["joint_q"][:, 3:7],
            "lin_vel": tv["base_lin_vel"],
            "ang_vel": tv["base_ang_vel"],
            "height": tv["base_height"],
            "gravity": tv["projected_gravity"],
            "yaw": tv["base_yaw"],
        }

    # --- rsl-rl interface -----------------------------------------------------------------------------------------
    def get_observations(self) -> TensorDict:
        return self._obs

    @property
    def collect_training_data(self) -> bool:
        """True while a training runner collects rollouts: the env stores (history, true state) pairs for the
        estimator and labelled power windows for the predictor, and the predictive selector samples at the
        schedule's temperature. False (the default: evaluation, playback, export) stores nothing, so nothing can
        learn, and the selector uses ``predictor.evaluation_selection``. ``WqRunner.learn`` sets it; the learning
        itself happens in the algorithm after PPO's update (``wqwarp.rl.algorithm.WqPPO``), never in :meth:`step`."""
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
        if cfg.reward.only_positive:
            rewards.clamp_(min=0.0)
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
        error = tracking_error(self.commands, self.tv["base_lin_vel"], self.tv["base_ang_vel"])
        self.gait_selector.record_step(self.power_measured, error, self.active_gait(), self.commands, dones, fell)
        self.prev2_actions[:] = self.prev_actions
        self.prev_actions[:] = self.actions
        # Metrics see the state before resets; the observations below re-read it after resets and pushes.
        self.extras = {"time_outs": time_out.clone(), "log": self._step_metrics(self.base_state(), ~unstable)}
        if self.ramped.any():
            self.extras["log"]["Reward/ramp_scale"] = self.reward_ramp_scale
        if self.ramp_gated and self.collect_training_data:
            vy_error = self.extras["log"]["Metrics/vy_error"]
            self.gate_error += torch.stack([vy_error, torch.ones_like(vy_error)])
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

    def set_iteration(self, iteration: int, gate_opened_at: int | None = None) -> None:
        """Weights of the PPO iteration the coming rollout belongs to: the ramped terms' full weights times
        ``RewardConfig.ramp_scale(iteration)`` (a function of the iteration, so a resumed run continues the ramp
        where it was); with the skill gate, 0 until ``gate_opened_at`` and the ramp from there."""
        if not self.ramped.any():
            return
        if self.ramp_gated:
            opened = gate_opened_at is not None
            self.reward_ramp_scale = self.cfg.reward.ramp_scale(iteration, gate_opened_at) if opened else 0.0
        else:
            self.reward_ramp_scale = self.cfg.reward.ramp_scale(iteration)
        scale = np.where(self.ramped, np.float32(self.reward_ramp_scale), np.float32(1.0))
        self.reward_weights.assign(self.full_reward_weights * scale)

    def take_gate_error(self) -> float | None:
        """Mean Metrics/vy_error of the training steps since the last call (None without any), and restart."""
        total, steps = self.gate_error.tolist()
        self.gate_error.zero_()
        return total / steps if steps else None

    def refresh_after_load(self) -> None:
        """Observe again, with every robot due for a gait selection, after networks were loaded into the env: the
        estimate in o_t and the gait each robot is reset into would otherwise come from the networks the env was
        built with (random initialisation), so the first seconds of a rollout would depend on torch's global RNG."""
        self.gait_selector.request_selection()
        self._obs = self._observe()

    def _observe(self) -> TensorDict:
        """o_t and the critic's observation, then the gait selection that reads o_t."""
        obs = self._compute_observations()
        self.gait_selector.select(obs["policy"], self.active_gait(), self.commands)
        return obs

    # --- actions -------------------------------------------------------------------------------------------------
    def _apply_actions(self) -> None:
        cfg, sim, a = self.cfg.action, self.sim, self.actions
        if self.residual_mode:
            ng = self.nominal
            wp.to_torch(ng.phase_residual)[:] = torch.clamp(cfg.phase_scale * a[:, :4], -cfg.phase_clip, cfg.phase_clip)
            ng.step(sim.actuated_q[:, :12], sim.wheel_contact, self.dt)
            wp.launch(
                residual_targets,
                dim=(self.num_envs, 4),
                inputs=[
                    self.actions_wp,
                    ng.foot_target,
                    ng.wheel_velocity,
                    int(cfg.use_nominal_wheels),
                    cfg.foot_scale,
                    cfg.foot_clip,
                    cfg.wheel_scale,
                    cfg.wheel_clip,
                ],
                outputs=[self.foot_residual_wp, sim.leg_q_target, sim.wheel_qd_target],
                device=sim.device,
            )
        else:
            wp.launch(
                joint_offset_targets,
                dim=self.num_envs,
                inputs=[self.actions_wp, self.default_leg_q_wp, cfg.joint_scale, cfg.wheel_scale, cfg.wheel_clip],
                outputs=[sim.leg_q_target, sim.wheel_qd_target],
                device=sim.device,
            )

    # --- rewards and logs ----------------------------------------------------------------------------------------
    def _compute_rewards(self) -> torch.Tensor:
        wp.launch(
            self.reward_kernel,
            dim=self.num_envs,
            inputs=[self.reward_inputs, self.reward_weights],
            outputs=[self.reward_wp, self.reward_terms_wp, self.episode_sums_wp],
            device=self.sim.device,
        )
        return self.reward_buf

    def _reward_inputs(self) -> RewardInputs:
        """The reward kernel's inputs: views of buffers allocated once (simulator and env)."""
        sim, inp = self.sim, RewardInputs()
        inp.base_lin_vel, inp.base_ang_vel = sim.base_lin_vel, sim.base_ang_vel
        inp.projected_gravity, inp.command = sim.projected_gravity, self.commands_wp
        inp.action, inp.prev_action, inp.prev2_action = self.actions_wp, self.prev_actions_wp, self.prev2_actions_wp
        inp.actuated_qd, inp.prev_actuated_qd = sim.actuated_qd, self.prev_qd_wp
        inp.torque_sq, inp.power_sq, inp.body_collision = sim.torque_sq, sim.power_sq, sim.body_collision
        inp.p_cost, inp.actuated_q = getattr(sim, self.cfg.reward_power_output), sim.actuated_q
        inp.joint_soft_low, inp.joint_soft_high = self.joint_soft_limits_wp
        inp.sigma, inp.dt = self.cfg.reward.tracking_sigma, self.dt
        return inp

    def _step_metrics(self, b: dict, valid: torch.Tensor) -> dict:
        """Means over the robots whose step is ``valid`` (not diverged)."""
        count = valid.float().sum().clamp(min=1.0)

        def mean(x: torch.Tensor, over: torch.Tensor | None = None) -> torch.Tensor:
            """Mean of x over the valid robots, or over the robots ``over`` (a subset of them)."""
            n = count if over is None else over.float().sum().clamp(min=1.0)
            return torch.where(valid if over is None else over, x, torch.zeros_like(x)).sum() / n

        err = torch.abs(b["lin_vel"][:, :2] - self.commands[:, :2])
        werr = torch.abs(b["ang_vel"][:, 2] - self.commands[:, 2])
        out = {"Metrics/vx_error": mean(err[:, 0]), "Metrics/vy_error": mean(err[:, 1]), "Metrics/wz_error": mean(werr)}
        for k in REPORTED_POWER:
            out[f"Metrics/{k}"] = mean(self.tv[k])
        label = self.gait_selector.label_robots
        if label is not None:  # what exploration costs: the same selection, with and without the action noise
            for name, part in (("mean_actors", label), ("sampled", ~label)):
                out[f"Metrics/p_cost_{name}"] = mean(self.tv["p_cost"], valid & part)
        mag = self.actions.abs()
        for name, cols in self.action_groups.items():  # mean |a| per action group, raw (before scales)
            out[f"Actions/{name}_abs"] = mean(mag[:, cols].mean(1))
        return out

    def _episode_log(self, ids: torch.Tensor, unstable: torch.Tensor) -> dict:
        """Per-term episode rewards per second over the ended episodes that did not diverge, and the shares of
        ended episodes that ended by a base contact or by a diverged simulation."""
        bad = unstable[ids]
        ok = (~bad).float()  # masked means: no boolean selection (a host synchronisation on CUDA)
        seconds = torch.clamp(self.episode_length_buf[ids].float() * self.dt, min=self.dt)
        count = ok.sum().clamp(min=1.0)
        log = {}
        for k, name in enumerate(self.reward_names):
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
        for k in POWER_OUTPUTS:
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
        self.commands[ids] = sample_commands(self.cfg.commands, len(ids), self.gen, self.device)

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
        self.tv["joint_qd"][:, 0:2] += events.push_to_world(self.tv["base_yaw"], dv)
        self.sim.state_written()

    # --- observations ---------------------------------------------------------------------------------------------
    def noise(self, shape, scale: float) -> torch.Tensor:
        """Uniform noise in [-scale, scale] from ``self.gen`` (zeros with ``obs.noise`` off or scale 0)."""
        if not self.cfg.obs.noise or scale == 0.0:
            return torch.zeros(shape, device=self.device)
        return (2.0 * torch.rand(shape, generator=self.gen, device=self.device) - 1.0) * scale

    def _compute_observations(self) -> TensorDict:
        """The registry's terms (``wqwarp.rl.observations``): the proprioceptive terms, the history and the
        estimate z_t inserted at ``estimate_index``, then the privileged terms."""
        n = self.num_envs
        b = self.base_state()
        proprio = torch.cat(obs_terms.compute_terms(self, self._proprio_terms, b), 1)
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
        zs = z * self.estimate_scale
        split = self.estimate_index
        actor = torch.cat([proprio[:, :split], zs, proprio[:, split:]], 1)
        priv = torch.cat(obs_terms.compute_terms(self, PRIVILEGED_TERMS, b), 1)
        return TensorDict({"policy": actor, "privileged": priv}, batch_size=[n], device=self.device)

    def mirror_observations(self, obs: TensorDict) -> TensorDict:
        """Left-right mirror of each observation group (``wqwarp.rl.observations.mirror_observations``)."""
        return obs_terms.mirror_observations(self, obs)

    def mirror_actions(self, actions: torch.Tensor) -> torch.Tensor:
        """Left-right mirror of actions (..., A) (``wqwarp.rl.observations.action_mirror``)."""
        return obs_terms.mirror_actions(self, actions)

    def close(self) -> None:
        pass
