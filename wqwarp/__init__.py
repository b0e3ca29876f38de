"""wqwarp: energy-aware gait selection for a wheeled Unitree Go1, on NVIDIA Warp and Newton."""

__version__ = "0.1.0"
