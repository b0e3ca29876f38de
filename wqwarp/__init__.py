"""wqwarp: energy-aware gait selection for a wheeled Unitree Go1, on NVIDIA Warp and Newton."""

import os as _os

__version__ = "0.1.0"

if not _os.environ.get("WQWARP_VERBOSE"):
    import warp as _wp

    # Warp prints its banner and a line per compiled/loaded module; set WQWARP_VERBOSE=1 to see them.
    _wp.config.quiet = True
    _wp.config.log_level = _wp.LOG_WARNING
