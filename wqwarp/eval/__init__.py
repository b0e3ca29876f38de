"""Evaluation of trained checkpoints: the paper's protocols, registered once, and the results report.

- ``protocols``: the registry (``PROTOCOLS``), :func:`run_protocol` and the command line of ``train/evaluate.py``
- ``tracking``: tracking, push recovery (Table III) and sim-to-sim; ``timeline``: Fig. 6; ``energy_map``: the gait
  energy map
- ``metrics``: the tasks and their metrics; ``rollout``: how a protocol drives an env and leaves it as found
- ``options``: a protocol's options as a dataclass that is also its command line
- ``physics``: the physics variants of sim-to-sim and the evaluation configuration
- ``loading``: a checkpoint into an env and its policy (``make_policy_runner``)
- ``reproduce``: ``train/reproduce.py``'s stages and budgets; ``report``: the results page
"""
