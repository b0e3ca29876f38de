"""Predictive gait selection: window labels, softmax sampling and the temperature schedule, the power predictor's
fit, the env's gait bookkeeping, and that evaluation and export never change a learned parameter."""

from __future__ import annotations

import json

import pytest
import torch

from wqwarp.rl.config import PredictorConfig
from wqwarp.rl.gait_selection import (
    COMMAND_TYPES,
    PowerPredictor,
    PredictiveGaitSelector,
    TemperatureSchedule,
    WindowLabeler,
    both_candidates,
    command_type,
    feasible_gaits,
    gait_probabilities,
    tracking_error,
)
from wqwarp.rl.presets import make_preset

GAITS = ("driving", "trotting", "walking")


# --- window labelling ------------------------------------------------------------------------------------------------
def test_windows_are_labelled_with_the_realised_mean_and_cut_windows_are_dropped():
    # Four robots, horizon 3 steps. Robot 0 runs gait 1 throughout; robot 1 is reset in its second step; robot 2's
    # running gait changes in its third step; robot 3 has a switch pending (requested 2, running 0) at the start.
    lab = WindowLabeler(4, obs_dim=2, horizon=3)
    obs0 = torch.arange(8, dtype=torch.float32).reshape(4, 2)
    active = torch.tensor([1, 1, 1, 0])
    lab.start(obs0, active, requested=torch.tensor([1, 1, 1, 2]))
    assert lab.open.tolist() == [True, True, True, False]
    no = torch.zeros(4, dtype=torch.bool)
    p = [
        torch.tensor([1.0, 10.0, 100.0, 5.0]),
        torch.tensor([2.0, 20.0, 200.0, 5.0]),
        torch.tensor([6.0, 30.0, 300.0, 5.0]),
    ]
    err = [0.1 * q for q in p]  # squared tracking errors, labelled alongside
    out = lab.step(p[0], err[0], active, no)
    assert len(out[2]) == 0
    out = lab.step(p[1], err[1], active, torch.tensor([False, True, False, False]))  # robot 1 reset
    assert len(out[2]) == 0 and lab.open.tolist() == [True, False, True, False]
    out = lab.step(p[2], err[2], torch.tensor([1, 1, 2, 0]), no)  # robot 2's gait switched
    x, g, y, e = out
    assert y.tolist() == [pytest.approx(3.0)]  # (1 + 2 + 6) / 3, robot 0 only
    assert e.tolist() == [pytest.approx(0.3)]
    assert g.tolist() == [1] and x.tolist() == [[0.0, 1.0]]
    assert lab.dropped == 2 and not lab.open.any()
    # A new window starts only where the requested gait is running.
    lab.start(obs0 + 1, torch.tensor([1, 1, 2, 0]), requested=torch.tensor([1, 0, 2, 2]))
    assert lab.open.tolist() == [True, False, True, False]


def test_with_command_cut_a_window_whose_command_changes_is_dropped_and_without_it_labelled():
    # Two robots, horizon 2, both in gait 1; robot 1's command is resampled before its second step.
    obs0 = torch.zeros(2, 2)
    active, no = torch.tensor([1, 1]), torch.zeros(2, dtype=torch.bool)
    held = torch.tensor([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    changed = torch.tensor([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    p = [torch.tensor([2.0, 2.0]), torch.tensor([4.0, 30.0])]
    labels = {}
    for cut in (False, True):
        lab = WindowLabeler(2, obs_dim=2, horizon=2, command_cut=cut)
        lab.start(obs0, active, requested=active, commands=held)
        assert len(lab.step(p[0], p[0], active, no, held)[2]) == 0
        labels[cut] = lab.step(p[1], p[1], active, no, changed)[2].tolist()
        assert int(lab.dropped) == int(cut)
    assert labels[False] == [pytest.approx(3.0), pytest.approx(16.0)]  # robot 1: half stand, half 1 m/s
    assert labels[True] == [pytest.approx(3.0)]  # robot 0 only
    with pytest.raises(ValueError, match="command_cut needs"):
        WindowLabeler(2, obs_dim=2, horizon=2, command_cut=True).start(obs0, active, requested=active)
    sel = _selector(2, label_command_cut=True)
    assert sel.labeler.command_cut and not _selector(2).labeler.command_cut


def _selector(n: int, dt: float = 1.0 / 3.0, **over) -> PredictiveGaitSelector:
    kw = {"horizon_s": 1.0, "decision_interval_s": 1.0, "buffer_size": 64, "holdout_fraction": 0.25, **over}
    cfg = PredictorConfig(**kw)
    sel = PredictiveGaitSelector(torch.zeros(n, dtype=torch.int32), GAITS, 1, dt, obs_dim=2, cfg=cfg)
    sel.training = True
    return sel


def _constant_power(sel: PredictiveGaitSelector, watts) -> None:
    """Set the predictor's parameters so that it predicts ``watts`` for every observation."""
    with torch.no_grad():
        for prm in sel.predictor.net.parameters():
            prm.zero_()
        sel.predictor.net[-1].bias.copy_(torch.tensor(watts))


def test_selector_holds_a_gait_for_the_decision_interval_and_labels_one_window_per_selection():
    # Horizon = decision interval = 3 policy steps. The predictor makes trotting (1) the only choice (tau -> 0).
    sel = _selector(2, temperature_start=1e-6, temperature_end=1e-6)
    _constant_power(sel, [9.0, 1.0, 9.0])
    obs = torch.tensor([[0.5, -0.5], [1.0, 2.0]])
    running = torch.tensor([1, 1])
    cmd = torch.zeros(2, 3)
    no = torch.zeros(2, dtype=torch.bool)
    sel.select(obs, running)  # both due at start
    assert sel.requested.tolist() == [1, 1] and not sel.due.any()
    for k, watts in enumerate([3.0, 4.0, 8.0]):
        sel.record_step(torch.tensor([watts, 1.0]), torch.zeros(2), running, cmd, no, no)
        if k < 2:
            assert not sel.due.any()
            sel.select(obs, running)
    assert sel.due.all() and sel.replay.n + sel.holdout.n == 2
    labels = sorted(torch.cat([sel.replay.y[: sel.replay.n], sel.holdout.y[: sel.holdout.n]]).tolist())
    assert labels == [pytest.approx(1.0), pytest.approx(5.0)]
    # A reset makes a robot due at once and drops its open window.
    sel.select(obs, running)
    sel.record_step(
        torch.tensor([1.0, 1.0]), torch.zeros(2), running, cmd, torch.tensor([True, False]), torch.tensor([True, False])
    )
    sel.on_reset(torch.tensor([0]))
    assert sel.due.tolist() == [True, False] and sel.labeler.dropped == 1


# --- sampling and temperature ----------------------------------------------------------------------------------------
@pytest.mark.parametrize(("tau", "normalization"), [(2.0, "watts"), (5.0, "watts"), (0.3, "mean")])
def test_sampling_frequencies_match_the_softmax(tau, normalization):
    n = 20000
    watts = torch.tensor([4.0, 7.0, 10.0], dtype=torch.float64)
    sel = _selector(n, temperature_start=tau, temperature_end=tau, power_normalization=normalization)
    _constant_power(sel, watts.tolist())
    sel.select(torch.zeros(n, 2), torch.ones(n, dtype=torch.long))
    freq = torch.bincount(sel.requested.long(), minlength=3).double() / n
    p = watts if normalization == "watts" else watts / watts.mean()  # mean: tau is a fraction of the mean power
    expect = torch.softmax(-p / tau, 0)
    # Each frequency is binomial: 4.5 standard deviations bound a false failure at about 1e-5.
    sigma = torch.sqrt(expect * (1 - expect) / n)
    assert torch.all((freq - expect).abs() < 4.5 * sigma), (freq, expect)


def test_tau_to_zero_gives_the_argmin_and_large_tau_uniform():
    p = torch.tensor([[3.0, 1.0, 2.0], [0.5, 0.7, 0.1]])
    assert gait_probabilities(p, 0.0).argmax(1).tolist() == [1, 2]
    assert torch.allclose(gait_probabilities(p, 1e-4), torch.tensor([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]))
    assert torch.allclose(gait_probabilities(p, 1e6), torch.full((2, 3), 1 / 3), atol=1e-5)
    # Outside training the selector takes the argmin (evaluation default), whatever the schedule says.
    sel = _selector(500, temperature_start=1e3, temperature_end=1e3)
    sel.training = False
    _constant_power(sel, [2.0, 1.9, 2.1])
    sel.select(torch.zeros(500, 2), torch.ones(500, dtype=torch.long))
    assert sel.temperature == 0.0 and (sel.requested == 1).all()


@pytest.mark.parametrize("shape", ["exponential", "linear", "cosine"])
def test_temperature_schedule_is_monotone_between_its_ends(shape):
    s = TemperatureSchedule(100.0, 1.0, 1000, shape)
    vals = [s(i) for i in range(0, 1201, 25)]
    assert vals[0] == pytest.approx(100.0) and s(1000) == pytest.approx(1.0) and s(5000) == pytest.approx(1.0)
    assert all(a >= b for a, b in zip(vals, vals[1:], strict=False))
    assert all(1.0 - 1e-9 <= v <= 100.0 + 1e-9 for v in vals)
    if shape == "exponential":
        assert s(500) == pytest.approx(10.0)  # geometric mean halfway
    with pytest.raises(ValueError, match="temperature"):
        TemperatureSchedule(0.0, 1.0, 10)
    with pytest.raises(ValueError, match="shape"):
        TemperatureSchedule(10.0, 1.0, 10, "step")


def test_command_types():
    cmd = torch.tensor([[0.5, 0, 0], [0, -0.3, 0], [0, 0, 0.6], [0.5, 0.2, 0], [0.01, 0, 0.02]])
    assert [COMMAND_TYPES[i] for i in command_type(cmd)] == ["forward", "lateral", "yaw", "mixed", "zero"]


# --- the feasible criterion (beyond the paper) ------------------------------------------------------------------------
def test_tracking_error_and_the_candidates_within_the_margin():
    cmd = torch.tensor([[0.5, 0.3, -0.2], [0.0, 0.0, 0.0]])
    lin = torch.tensor([[0.4, 0.0, 9.0], [0.1, -0.1, 0.0]])  # v_z never counts
    ang = torch.tensor([[5.0, 5.0, 0.1], [0.0, 0.0, 0.2]])  # only w_z counts
    assert tracking_error(cmd, lin, ang).tolist() == pytest.approx([0.01 + 0.09 + 0.09, 0.01 + 0.01 + 0.04])
    err = torch.tensor([[0.20, 0.010, 0.015], [0.001, 0.002, 0.050]])
    assert feasible_gaits(err, 0.02).tolist() == [[False, True, True], [True, True, False]]
    assert feasible_gaits(err, 0.001).tolist() == [[False, True, False], [True, True, False]]
    p = torch.tensor([[1.0, 9.0, 5.0], [3.0, 1.0, 0.5]])
    cand = feasible_gaits(err, 0.02)
    assert gait_probabilities(p, 0.0, cand).argmax(1).tolist() == [2, 1]  # cheapest candidate, not cheapest gait
    probs = gait_probabilities(p, 1e6, cand)  # hot: uniform over the candidates, never a gait that cannot track
    assert torch.allclose(probs, torch.tensor([[0.0, 0.5, 0.5], [0.5, 0.5, 0.0]]), atol=1e-5)


def test_the_feasible_selector_picks_the_cheapest_gait_predicted_to_track():
    sel = _selector(6, temperature_start=1e-6, temperature_end=1e-6, criterion="feasible", feasible_margin=0.02)
    _constant_power(sel, [1.0, 9.0, 5.0])  # driving the cheapest
    obs, running = torch.zeros(6, 2), torch.ones(6, dtype=torch.long)
    sel.select(obs, running)
    assert (sel.requested == 0).all()  # the tracking head is not fitted yet: every gait is a candidate
    with torch.no_grad():
        for prm in sel.tracker.net.parameters():
            prm.zero_()
        sel.tracker.net[-1].bias.copy_(torch.tensor([0.2, 0.01, 0.015]))  # driving cannot track this command
    sel.tracker_fitted = True
    sel.request_selection()
    sel.select(obs, running)
    assert (sel.requested == 2).all()  # walking: the cheaper of the two that track
    assert sel.log_scalars()["Gait/candidates_per_selection"] == pytest.approx(2.0)  # counted once fitted
    sel.cfg.feasible_margin = 0.001
    sel.request_selection()
    sel.select(obs, running)
    assert (sel.requested == 1).all()
    # While training at a finite tau a non-candidate keeps odds e^(-penalty / tau) against a candidate of equal
    # power (penalty in units of the mean predicted power); the argmin (evaluation) never picks it.
    n = 20000
    hot = _selector(n, temperature_start=0.5, temperature_end=0.5, criterion="feasible", feasible_penalty=0.5)
    _constant_power(hot, [6.0, 6.0, 6.0])
    with torch.no_grad():
        for prm in hot.tracker.net.parameters():
            prm.zero_()
        hot.tracker.net[-1].bias.copy_(torch.tensor([0.3, 0.01, 0.015]))
    hot.tracker_fitted = True
    hot.select(torch.zeros(n, 2), torch.ones(n, dtype=torch.long))
    freq = torch.bincount(hot.requested.long(), minlength=3).double() / n
    expect = torch.softmax(-torch.tensor([1.0 + 0.5, 1.0, 1.0], dtype=torch.float64) / 0.5, 0)
    assert torch.all((freq - expect).abs() < 4.5 * torch.sqrt(expect * (1 - expect) / n)), (freq, expect)
    hot.training = False
    hot.request_selection()
    hot.select(torch.zeros(n, 2), torch.ones(n, dtype=torch.long))
    assert (hot.requested != 0).all()
    # The paper's rule builds no tracking head (and draws nothing more from torch's RNG).
    assert _selector(2).tracker is None


def test_the_kinematic_criterion_keeps_lateral_commands_off_the_gait_without_swing():
    from wqwarp.rl.config import EnvConfig
    from wqwarp.rl.gait_selection import make_gait_selector

    cfg = EnvConfig()
    cfg.gait.selection, cfg.predictor.criterion = "predictive", "kinematic"
    cfg.predictor.temperature_start = cfg.predictor.temperature_end = 1e6  # uniform over the candidates
    n = 6000
    sel = make_gait_selector(cfg, torch.zeros(n, dtype=torch.int32), GAITS, 1, 0.02, obs_dim=2)
    assert sel.stepless.tolist() == [True, False, False]  # driving has no swing
    sel.training = True
    _constant_power(sel, [1.0, 9.0, 5.0])
    cmd = torch.zeros(n, 3)
    cmd[: n // 2, 1] = torch.where(torch.arange(n // 2) % 2 == 0, 0.3, -0.3)  # lateral; the rest forward
    cmd[n // 2 :, 0] = 0.8
    cmd[n // 2 :, 1] = 0.05  # below the limit: every gait a candidate
    sel.select(torch.zeros(n, 2), torch.ones(n, dtype=torch.long), cmd)
    lateral, forward = sel.requested[: n // 2].long(), sel.requested[n // 2 :].long()
    assert (lateral != 0).all() and set(lateral.tolist()) == {1, 2}
    assert set(forward.tolist()) == {0, 1, 2}
    sel.training = False  # the argmin: the cheapest candidate
    sel.request_selection()
    sel.select(torch.zeros(n, 2), torch.ones(n, dtype=torch.long), cmd)
    assert (sel.requested[: n // 2] == 2).all() and (sel.requested[n // 2 :] == 0).all()
    # a yaw limit (off by default) keeps fast turns off the driving gait too
    turns = torch.tensor([[0.0, 0.0, 0.5], [0.0, 0.0, -0.5], [0.8, 0.0, 0.2], [0.0, 0.05, 0.0]])
    assert sel.kinematic_candidates(turns).all()  # default 10 rad/s: every gait for every turn
    sel.cfg.kinematic_yaw_limit = 0.3
    assert sel.kinematic_candidates(turns)[:, 0].tolist() == [False, False, True, True]
    assert sel.kinematic_candidates(turns)[:, 1:].all()


def test_the_reach_mask_keeps_lateral_commands_beyond_a_gaits_stroke_off_it():
    # Table I at lateral_limit 0.12 m: trotting sweeps 0.24 m in (1 - 0.4) / 1.2 = 0.5 s of stance (0.48 m/s),
    # walking in (1 - 0.225) / 0.8 = 0.96875 s (0.2477 m/s); driving has no stroke (its own limit, 0.1 m/s).
    from wqwarp.control.gaits import TABLE_I
    from wqwarp.rl.config import EnvConfig
    from wqwarp.rl.gait_selection import lateral_reach, make_gait_selector

    assert [lateral_reach(g, 0.12) for g in TABLE_I] == pytest.approx([0.0, 0.48, 0.24 / 0.96875])
    cfg = EnvConfig()
    cfg.gait.selection, cfg.predictor.criterion = "predictive", "kinematic"
    cfg.predictor.kinematic_reach = True
    with pytest.raises(ValueError, match="lateral_gain"):
        make_gait_selector(cfg, torch.zeros(4, dtype=torch.int32), GAITS, 1, 0.02, obs_dim=2)
    cfg.gait.lateral_gain = 0.35
    sel = make_gait_selector(cfg, torch.zeros(5, dtype=torch.int32), GAITS, 1, 0.02, obs_dim=2)
    cmd = torch.tensor([[0.0, 0.05, 0.0], [0.0, -0.2, 0.0], [0.0, 0.3, 0.0], [0.0, -0.6, 0.0], [0.5, 0.0, 0.4]])
    expect = [[True, True, True], [False, True, True], [False, True, False], [False, True, False], [True, True, True]]
    assert sel.kinematic_candidates(cmd).tolist() == expect  # trotting, the widest reach, stays beyond 0.48
    _constant_power(sel, [1.0, 9.0, 5.0])
    sel.select(torch.zeros(5, 2), torch.ones(5, dtype=torch.long), cmd)  # the argmin: cheapest candidate
    assert sel.requested.tolist() == [0, 2, 1, 1, 0]
    cfg.predictor.criterion = "power"  # the mask belongs to the kinematic criteria
    with pytest.raises(ValueError, match="kinematic criterion"):
        make_gait_selector(cfg, torch.zeros(4, dtype=torch.int32), GAITS, 1, 0.02, obs_dim=2)


def test_exploration_picks_uniformly_among_the_kinematic_candidates_in_training_only():
    # Power makes walking the certain choice (tau small); with explore_fraction 0.3 a lateral command goes to each
    # of the two stepping gaits with probability 0.15 by exploration (never to driving, which the kinematic mask
    # forbids), so trotting gets 0.15 and walking 0.85; a forward command explores over all three (0.1 each).
    from wqwarp.rl.config import EnvConfig
    from wqwarp.rl.gait_selection import make_gait_selector

    cfg = EnvConfig()
    cfg.gait.selection, cfg.predictor.criterion = "predictive", "kinematic"
    cfg.predictor.temperature_start = cfg.predictor.temperature_end = 0.01
    cfg.predictor.explore_fraction = 0.3
    n = 40000
    sel = make_gait_selector(cfg, torch.zeros(n, dtype=torch.int32), GAITS, 1, 0.02, obs_dim=2)
    sel.training = True
    _constant_power(sel, [1.0, 9.0, 5.0])
    cmd = torch.zeros(n, 3)
    cmd[: n // 2, 1] = 0.4
    cmd[n // 2 :, 0] = 0.8
    sel.select(torch.zeros(n, 2), torch.ones(n, dtype=torch.long), cmd)
    m = n // 2
    for rows, expect in ((slice(0, m), [0.0, 0.15, 0.85]), (slice(m, n), [0.8, 0.1, 0.1])):
        freq = torch.bincount(sel.requested[rows].long(), minlength=3).double() / m
        p = torch.tensor(expect, dtype=torch.float64)
        assert torch.all((freq - p).abs() <= 4.5 * torch.sqrt(p * (1 - p) / m) + 1e-12), (freq, p)
    assert sel.log_scalars()["Gait/explored_share"] == pytest.approx(0.3, abs=0.02)
    sel.training = False  # evaluation: the argmin, never explored
    sel.request_selection()
    sel.select(torch.zeros(n, 2), torch.ones(n, dtype=torch.long), cmd)
    assert (sel.requested[:m] == 2).all() and (sel.requested[m:] == 0).all()
    assert PredictorConfig().explore_fraction == 0.0  # off by default (tests/test_behaviour_reference.py: unchanged)


def test_kinematic_feasible_sends_a_lateral_command_to_the_cheapest_stepping_gait_predicted_to_track():
    # Predicted squared errors: driving 0.01 (it stands still, and standing is what the head saw), trotting 0.05,
    # walking 0.12; power: driving 1, trotting 9, walking 5. Each criterion's argmin for a lateral command:
    # feasible -> driving (tracks best), kinematic -> walking (the cheaper stepping gait), kinematic_feasible ->
    # trotting (walking is more than the margin worse than the best stepping gait).
    from wqwarp.rl.config import EnvConfig
    from wqwarp.rl.gait_selection import make_gait_selector

    err = torch.tensor([[0.01, 0.05, 0.12], [0.01, 0.05, 0.12], [0.01, 0.05, 0.12]])
    allowed = torch.tensor([[False, True, True], [True, True, True], [False, False, True]])
    assert feasible_gaits(err, 0.02, allowed).tolist() == [
        [False, True, False],
        [True, False, False],
        [False, False, True],
    ]
    lateral_and_forward = torch.tensor([[0.0, 0.4, 0.0], [0.8, 0.0, 0.0]])
    picks = {}
    for criterion in ("feasible", "kinematic", "kinematic_feasible"):
        cfg = EnvConfig()
        cfg.gait.selection, cfg.predictor.criterion = "predictive", criterion
        cfg.predictor.temperature_start = cfg.predictor.temperature_end = 1e-6
        sel = make_gait_selector(cfg, torch.zeros(2, dtype=torch.int32), GAITS, 1, 0.02, obs_dim=2)
        assert (sel.tracker is not None) == (criterion != "kinematic")
        _constant_power(sel, [1.0, 9.0, 5.0])
        if sel.tracker is not None:
            with torch.no_grad():
                for prm in sel.tracker.net.parameters():
                    prm.zero_()
                sel.tracker.net[-1].bias.copy_(err[0])
            sel.tracker_fitted = True
        sel.select(torch.zeros(2, 2), torch.ones(2, dtype=torch.long), lateral_and_forward)
        picks[criterion] = sel.requested.tolist()
        # the energy map asks the same rule with a cell's mean prediction in place of the head's output
        cand = both_candidates(*sel.rule_candidates(None, lateral_and_forward, err[:2]))
        if criterion == "kinematic_feasible":
            assert cand.tolist() == [[False, True, False], [True, False, False]]
    assert picks == {"feasible": [0, 0], "kinematic": [2, 0], "kinematic_feasible": [1, 0]}
    # While training (tau > 0) the kinematic mask stays hard and the margin is softened: a lateral command never
    # goes to driving, walking keeps odds e^(-penalty / tau) against trotting at equal power.
    n = 20000
    cfg = EnvConfig()
    cfg.gait.selection, cfg.predictor.criterion = "predictive", "kinematic_feasible"
    cfg.predictor.temperature_start = cfg.predictor.temperature_end = 0.5
    cfg.predictor.feasible_penalty = 0.5
    hot = make_gait_selector(cfg, torch.zeros(n, dtype=torch.int32), GAITS, 1, 0.02, obs_dim=2)
    hot.training = True
    _constant_power(hot, [6.0, 6.0, 6.0])
    with torch.no_grad():
        for prm in hot.tracker.net.parameters():
            prm.zero_()
        hot.tracker.net[-1].bias.copy_(err[0])
    hot.tracker_fitted = True
    hot.select(torch.zeros(n, 2), torch.ones(n, dtype=torch.long), torch.tensor([[0.0, 0.4, 0.0]]).repeat(n, 1))
    freq = torch.bincount(hot.requested.long(), minlength=3).double() / n
    expect = torch.softmax(-torch.tensor([1.0, 1.0 + 0.5], dtype=torch.float64) / 0.5, 0)
    assert freq[0] == 0.0
    assert torch.all((freq[1:] - expect).abs() < 4.5 * torch.sqrt(expect * (1 - expect) / n)), (freq, expect)


# --- the network -----------------------------------------------------------------------------------------------------
def test_predictor_fits_a_synthetic_power_function_of_the_observation():
    # p_g(o) = a_g + b_g * o0^2 + c_g * o1 with distinct coefficients per gait, labels only for the gait that ran.
    torch.manual_seed(0)
    n = 6000
    sel = _selector(1, learning_rate=3e-3, batch_size=256, updates_per_iteration=50, buffer_size=n)
    sel.predictor = PowerPredictor(2, 3, (64, 64))
    sel.optimizer = torch.optim.Adam(sel.predictor.parameters(), lr=3e-3)
    x = torch.rand(n, 2) * 2 - 1
    coef = torch.tensor([[5.0, 2.0, 1.0], [25.0, 10.0, -4.0], [40.0, -6.0, 8.0]])

    def truth(obs):
        return coef[:, 0] + coef[:, 1] * obs[:, :1] ** 2 + coef[:, 2] * obs[:, 1:2]

    gait = torch.randint(0, 3, (n,))
    y = truth(x).gather(1, gait[:, None]).squeeze(1)
    sel.add_windows(x, gait, y)
    for _ in range(30):
        out = sel.fit()
    xt = torch.rand(500, 2) * 2 - 1
    err = (sel.predict(xt) - truth(xt)).abs().mean(0)
    assert torch.all(err < torch.tensor([0.4, 0.8, 1.0])), err  # the spread of p per gait is 3, 14, 22 W
    for g in GAITS:  # the held-out relative error per gait is reported and small
        assert out[f"rel_error_{g}"] < 0.05


def test_the_tracking_head_fits_the_error_of_the_gait_that_ran():
    # e_g(o) = gait g's squared error: driving fails a lateral command o1 (e = o1^2), the legged gaits track it.
    torch.manual_seed(1)
    n = 4000
    sel = _selector(
        1, learning_rate=3e-3, batch_size=256, updates_per_iteration=50, buffer_size=n, criterion="feasible"
    )
    x = torch.rand(n, 2) * 2 - 1
    gait = torch.randint(0, 3, (n,))
    truth = torch.stack([x[:, 1] ** 2, 0.01 + 0.0 * x[:, 0], 0.02 + 0.01 * x[:, 0]], dim=1)
    e = truth.gather(1, gait[:, None]).squeeze(1)
    sel.add_windows(x, gait, torch.full((n,), 10.0), e)
    for _ in range(20):
        out = sel.fit()
    assert "tracking_loss" in out and sel.tracker_fitted
    xt = torch.tensor([[0.0, 0.8], [0.0, 0.05]])
    assert sel.candidate_gaits(xt).tolist() == [[False, True, True], [True, True, True]]
    assert out["tracking_abs_error_driving"] < 0.03


# --- the env and the runner ------------------------------------------------------------------------------------------
def _env(preset: str, n: int = 4, criterion: str = "power"):
    from wqwarp.rl.env import WheeledGo1Env

    cfg = make_preset(preset)
    cfg.predictor.criterion = criterion
    cfg.sim.num_envs = n
    cfg.predictor.batch_size = 8  # a tiny rollout completes only a few windows: fit on few, hold out half
    cfg.predictor.holdout_fraction = 0.5
    return WheeledGo1Env(cfg)


def test_requested_gait_has_one_home_and_the_critic_reads_the_running_gait():
    import warp as wp

    env = _env("ours", 6)
    env.collect_training_data = True
    _constant_power(env.gait_selector, [1.0, 50.0, 50.0])  # driving is (by far) the cheapest
    env.gait_selector.schedule = TemperatureSchedule(1e-3, 1e-3, 0)
    obs, *_ = env.step(torch.zeros(6, env.num_actions))
    req = wp.to_torch(env.nominal.gait_id)
    assert env.gait_selector.requested.data_ptr() == req.data_ptr()
    assert (env.requested_gait() == 0).all()
    onehot = obs["privileged"][:, -3:]
    running = env.active_gait()
    assert torch.equal(onehot.argmax(1), running)
    # Trotting -> driving waits for an all-stance moment; the critic follows the running gait, not the request.
    for _ in range(40):
        obs, *_ = env.step(torch.zeros(6, env.num_actions))
        assert torch.equal(obs["privileged"][:, -3:].argmax(1), env.active_gait())
    assert (env.active_gait() == 0).all()


@pytest.mark.parametrize(
    ("preset", "criterion"), [("ours", "power"), ("no_wheel_vel", "power"), ("ours", "kinematic_feasible")]
)
def test_predictive_presets_train_two_iterations_and_round_trip_the_predictor(preset, criterion, tmp_path):
    import contextlib
    import io

    from wqwarp.rl.config import TrainConfig
    from wqwarp.rl.export import export_onboard_policy
    from wqwarp.rl.runner import WqRunner

    env = _env(preset, 8, criterion)
    assert env.cfg.gait.selection == "predictive"
    assert env.cfg.action.use_nominal_wheels == (preset == "ours")
    tcfg = TrainConfig(num_steps_per_env=60, max_iterations=2, save_interval=1)
    with contextlib.redirect_stdout(io.StringIO()):
        runner = WqRunner(env, tcfg.rsl_rl_dict(), log_dir=str(tmp_path), device="cpu")
        runner.learn(2)
    sel = env.gait_selector
    assert sel.windows > 0 and sel.iteration == 2 and "predictor" in runner.alg.aux_losses
    assert not env.collect_training_data  # learning is over: the env stores nothing any more
    scalars = runner.logger.metrics  # the iteration's means, as written to metrics.jsonl
    assert scalars["Gait/temperature"] == pytest.approx(sel.schedule(1))
    assert sum(scalars[f"Gait/usage_{g}"] for g in GAITS) == pytest.approx(1.0)
    runner.logger.writer.flush()
    import subprocess
    import sys

    root = __file__.rsplit("/tests/", 1)[0]
    rep = subprocess.run(
        [
            sys.executable,
            f"{root}/tools/gait_report.py",
            str(tmp_path),
            "--last",
            "1",
            "--json",
            str(tmp_path / "rep.json"),
        ],
        capture_output=True,
        text=True,
    )
    assert rep.returncode == 0, rep.stderr
    logged = json.loads((tmp_path / "rep.json").read_text())["scalars"]
    assert logged["Gait/temperature"] == pytest.approx(scalars["Gait/temperature"])
    assert "Predictor/loss" in logged and any(k.startswith("Predictor/rel_error_") for k in logged)
    ckpt = torch.load(tmp_path / "model_1.pt", weights_only=False)
    state = ckpt["gait_selector_state_dict"]
    assert state["name"] == "predictive" and state["iteration"] == 2

    env2 = _env(preset, 8, criterion)
    with contextlib.redirect_stdout(io.StringIO()):
        runner2 = WqRunner(env2, tcfg.rsl_rl_dict(), log_dir=None, device="cpu")
    runner2.load(str(tmp_path / "model_1.pt"))
    obs = env2.get_observations()["policy"]
    assert torch.equal(env2.gait_selector.predict(obs), sel.predict(obs))
    assert env2.gait_selector.iteration == 2
    if criterion == "kinematic_feasible":  # the tracking head learnt windows and travels with the checkpoint
        assert "Predictor/tracking_loss" in logged and sel.tracker_fitted and "tracker" in state
        assert torch.equal(env2.gait_selector.predict_error(obs), sel.predict_error(obs))
        paths = export_onboard_policy(runner2, str(tmp_path / "export"))
        policy = torch.export.load(paths["torch_export"]).module()
        meta = json.loads(open(paths["json"]).read())
        actions, power, error = policy(torch.zeros(3, meta["history_length"], meta["proprio_dim"]))
        assert error.shape == (3, 3)
        rule = meta["gait_selection"]["rule"]  # both masks, in the order the selector applies them
        assert rule.index("other than driving (no swing)") < rule.index("predicted_tracking_error <= the minimum of")
        return

    # The export returns the actions and each gait's predicted power; its json states the argmin rule.
    paths = export_onboard_policy(runner2, str(tmp_path / "export"))
    policy = torch.export.load(paths["torch_export"]).module()
    meta = json.loads(open(paths["json"]).read())
    actions, power = policy(torch.zeros(3, meta["history_length"], meta["proprio_dim"]))
    assert actions.shape == (3, 20) and power.shape == (3, 3) and torch.isfinite(power).all()
    assert meta["gait_selection"]["gaits"] == list(GAITS) and "argmin" in meta["gait_selection"]["rule"]


def test_a_fixed_gait_checkpoint_cannot_drive_the_predictive_selection(tmp_path):
    import contextlib
    import io

    from wqwarp.rl.config import TrainConfig
    from wqwarp.rl.runner import WqRunner

    env = _env("no_predictor")
    with contextlib.redirect_stdout(io.StringIO()):
        runner = WqRunner(env, TrainConfig().rsl_rl_dict(), log_dir=None, device="cpu")
    runner.save(str(tmp_path / "m.pt"))
    env2 = _env("ours")
    with contextlib.redirect_stdout(io.StringIO()):
        runner2 = WqRunner(env2, TrainConfig().rsl_rl_dict(), log_dir=None, device="cpu")
    with pytest.raises(ValueError, match="gait selector"):
        runner2.load(str(tmp_path / "m.pt"))


def test_estimator_and_predictor_do_not_change_during_evaluation_playback_or_export(tmp_path):
    import contextlib
    import io

    from wqwarp.eval.loading import make_policy_runner
    from wqwarp.eval.tracking import run_task
    from wqwarp.rl.config import TrainConfig
    from wqwarp.rl.export import export_onboard_policy
    from wqwarp.rl.runner import WqRunner

    env = _env("ours", 8)
    with contextlib.redirect_stdout(io.StringIO()):
        runner = WqRunner(env, TrainConfig(num_steps_per_env=60).rsl_rl_dict(), log_dir=str(tmp_path), device="cpu")
        runner.learn(1)
    ckpt = str(tmp_path / "model_0.pt")
    pr = make_policy_runner(ckpt, "ours", num_envs=4)

    def params():
        mods = [pr.env.estimator, pr.env.gait_selector.predictor]
        return [t.detach().clone() for m in mods for t in list(m.parameters()) + list(m.buffers())]

    before = params()
    res = run_task(pr, "vx", seconds=1.5, settle=0.5)
    assert res.mse_axes[0] == pytest.approx(res.mse) and res.mean_p_elec > 0.0
    assert sum(res.gait_usage.values()) == pytest.approx(1.0)
    for _ in range(60):  # playback (tools/export_usd.py --checkpoint drives the env the same way)
        pr.env.step(pr.policy(pr.env.get_observations()))
    with contextlib.redirect_stdout(io.StringIO()):
        runner2 = WqRunner(pr.env, TrainConfig().rsl_rl_dict(), log_dir=None, device="cpu")
    runner2.load(ckpt)
    export_onboard_policy(runner2, str(tmp_path / "export"))
    after = params()
    assert all(torch.equal(a, b) for a, b in zip(before, after, strict=True))
    assert pr.env.estimator_trainer._inputs == [] and pr.env.gait_selector.replay.n == 0


def test_selection_switches_only_when_no_leg_of_the_running_gait_swings():
    import warp as wp

    from wqwarp.control.gaits import GAIT_LIBRARY

    env = _env("ours", 8)
    env.collect_training_data = True
    env.gait_selector.schedule = TemperatureSchedule(1e6, 1e6, 0)  # uniform: many switches
    df = torch.tensor([g.df_swing for g in GAIT_LIBRARY])
    switches = 0
    for _ in range(150):
        before = env.active_gait().clone()
        phase = wp.to_torch(env.nominal.phase).clone()
        env.step(torch.zeros(8, env.num_actions))
        changed = (env.active_gait() != before) & (env.episode_length_buf > 0)  # not a reset
        switches += int(changed.sum())
        if changed.any():
            assert torch.all(phase[changed] >= df[before[changed]][:, None] - 1e-6)
    assert switches >= 8
    assert env.gait_selector.log_scalars()["Gait/switches_per_robot_minute"] > 0


def _sync_worker(rank: int, world: int, port: int, out_dir: str) -> None:
    import torch.distributed as dist

    from wqwarp.rl.algorithm import sync_module as _sync_module

    dist.init_process_group("gloo", init_method=f"tcp://127.0.0.1:{port}", rank=rank, world_size=world)
    torch.manual_seed(rank)  # different initial weights per rank
    m = PowerPredictor(4, 3, (8,))
    _sync_module(m, "broadcast")
    start = [t.clone() for t in m.state_dict().values()]
    with torch.no_grad():  # ranks fit different data: diverge, then average
        for t in m.parameters():
            t.add_(float(rank + 1))
    _sync_module(m, "average")
    torch.save({"start": start, "end": list(m.state_dict().values())}, f"{out_dir}/rank{rank}.pt")
    dist.destroy_process_group()


def test_auxiliary_learners_stay_identical_across_ranks(tmp_path):
    import socket

    import torch.multiprocessing as mp

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    mp.spawn(_sync_worker, args=(2, port, str(tmp_path)), nprocs=2, join=True)
    r0, r1 = (torch.load(tmp_path / f"rank{r}.pt") for r in (0, 1))
    assert all(torch.equal(a, b) for a, b in zip(r0["start"], r1["start"], strict=True))  # broadcast from rank 0
    assert all(torch.equal(a, b) for a, b in zip(r0["end"], r1["end"], strict=True))  # averaged
    torch.manual_seed(0)
    ref = PowerPredictor(4, 3, (8,))
    w0 = ref.net[0].weight
    assert torch.allclose(r0["end"][4], w0 + 1.5)  # state_dict order: 4 buffers, then net.0.weight


def test_a_forced_gait_overrides_the_selection_but_not_the_prediction():
    sel = _selector(4, temperature_start=1e-6, temperature_end=1e-6)
    _constant_power(sel, [1.0, 9.0, 5.0])
    sel.forced_gait = 2
    sel.select(torch.zeros(4, 2), torch.ones(4, dtype=torch.long))
    assert (sel.requested == 2).all()
    assert sel.predict(torch.zeros(1, 2)).argmin().item() == 0


def test_mean_labels_come_from_robots_acting_with_the_mean_that_ppo_leaves_out(tmp_path):
    """``label_source = mean``: every 4th robot acts with the actor's mean, only they open predictor windows, and
    their transitions carry advantage 0 and return = value; the others sample and their advantages are normalised
    among themselves; the control class keeps them in PPO with rsl-rl's advantages."""
    import contextlib
    import io

    from wqwarp.rl.config import TrainConfig
    from wqwarp.rl.env import WheeledGo1Env
    from wqwarp.rl.runner import WqRunner

    cfg = make_preset("ours")
    cfg.sim.num_envs = 8
    cfg.predictor.label_source = "mean"
    cfg.predictor.label_fraction = 0.25
    env = WheeledGo1Env(cfg)
    mask = env.gait_selector.label_robots
    assert mask.tolist() == [True, False, False, False, True, False, False, False]
    tcfg = TrainConfig(num_steps_per_env=60, max_iterations=1, save_interval=1)
    with contextlib.redirect_stdout(io.StringIO()):
        runner = WqRunner(env, tcfg.rsl_rl_dict(), log_dir=str(tmp_path), device="cpu")
        runner.learn(1)
    st = runner.alg.storage
    mean = st.distribution_params[0]
    assert torch.equal(st.actions[:, mask], mean[:, mask])
    assert (st.actions[:, ~mask] - mean[:, ~mask]).abs().mean() > 0.1  # sampled at the initial std
    assert torch.all(st.advantages[:, mask] == 0) and torch.equal(st.returns[:, mask], st.values[:, mask])
    kept = st.advantages[:, ~mask]
    assert abs(float(kept.mean())) < 1e-5 and float(kept.std()) == pytest.approx(1.0, abs=1e-3)
    sel = env.gait_selector
    assert not sel.labeler.open[~mask].any() and sel.labeler.open[mask].any()
    m = runner.logger.metrics  # exploration's cost is logged: the noise-free robots draw less power
    assert 0.0 < m["Metrics/p_cost_mean_actors"] < m["Metrics/p_cost_sampled"]
    # the control (--train.algorithm-class wqwarp.rl.algorithm:KeptMeanActorsPPO): same mean actors, kept in PPO
    tcfg.algorithm_class = "wqwarp.rl.algorithm:KeptMeanActorsPPO"
    with contextlib.redirect_stdout(io.StringIO()):
        control = WqRunner(env, tcfg.rsl_rl_dict(), log_dir=str(tmp_path / "control"), device="cpu")
        control.learn(1)
    st = control.alg.storage
    assert torch.equal(st.actions[:, mask], st.distribution_params[0][:, mask])
    assert float(st.advantages[:, mask].abs().mean()) > 0.1
    assert abs(float(st.advantages.mean())) < 1e-5 and float(st.advantages.std()) == pytest.approx(1.0, abs=1e-3)
