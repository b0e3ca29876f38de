"""wqwarp: energy-aware gait selection for a wheeled Unitree Go1, on NVIDIA Warp and Newton."""

import os as _os
import sys as _sys

__version__ = "0.1.0"


def quiet_warp() -> None:
    """Silence Warp's banner and its line per compiled/loaded module (set ``WQWARP_VERBOSE=1`` to see them). Called
    by ``wqwarp.kernels`` on import, so that importing a config never loads Warp."""
    if _os.environ.get("WQWARP_VERBOSE"):
        return
    import warp as wp

    wp.config.quiet = True
    wp.config.log_level = wp.LOG_WARNING


if "warp" in _sys.modules:  # imported already (by a script): quiet it now
    quiet_warp()
