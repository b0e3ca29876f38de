"""CPU thread counts of training: torch's intra-op threads and the physics threads (``mujoco.rollout``).

Both pools spin on the same cores. When torch asks for more threads than there are free cores (on a laptop, any other
busy process holds some), its OpenMP threads wait for the descheduled one at every synchronisation: with one of 2 cores
busy, torch's own default (2 threads) trained 1.8x slower than one thread, its PPO update 2.2x slower
(docs/performance.md; an earlier measurement on main saw 5-7x). The default gives torch one thread while collecting:
its networks are small and one core runs them, while the physics, the bulk of collection, gets every core.
"""

from __future__ import annotations

import os

DEFAULT_TORCH_THREADS = 1
"""Torch intra-op threads while collecting, by default (measured, docs/performance.md: the default settings
are the best idle and within 1.03x of the best with a core busy, where torch's own default is 1.8x slower)."""


def available_cores() -> int:
    """Cores this process may run on, shared among the processes of this machine under torchrun
    (``LOCAL_WORLD_SIZE``)."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cores = os.cpu_count() or 1
    return max(1, cores // max(1, int(os.getenv("LOCAL_WORLD_SIZE", "1"))))


def default_physics_threads() -> int:
    """Physics threads by default: every available core (:func:`available_cores`)."""
    return available_cores()


def default_update_threads() -> int:
    """Torch threads during the PPO update by default: half the available cores (1 on 2 cores, where 2 threads
    lose 3x when another process holds a core: docs/performance.md), so that one busy core never stalls the update
    while larger machines still run it in parallel."""
    return max(1, available_cores() // 2)


def configure_threads(
    threads: int | None = None,
    torch_threads: int | None = None,
    physics_threads: int | None = None,
    update_threads: int | None = None,
) -> dict[str, int]:
    """Resolve and apply the thread counts: ``threads`` sets both pools, ``torch_threads`` / ``physics_threads``
    override one. Sets torch's intra-op threads (collection) now; returns ``{"torch": T, "update": U, "physics": P}``:
    U for ``WqPPO.update_threads`` (``runner.alg``: the PPO update and the fits), P for ``SimConfig.nthread``."""
    import torch

    for name, v in (
        ("threads", threads),
        ("torch_threads", torch_threads),
        ("physics_threads", physics_threads),
        ("update_threads", update_threads),
    ):
        if v is not None and v < 1:
            raise ValueError(f"{name.replace('_', '-')} must be >= 1, got {v}")
    t = torch_threads or threads or DEFAULT_TORCH_THREADS
    p = physics_threads or threads or default_physics_threads()
    u = update_threads or threads or default_update_threads()
    torch.set_num_threads(t)
    return {"torch": t, "update": u, "physics": p}
