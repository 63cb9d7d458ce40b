"""rvtool: precision gear reducer simulation on Exudyn with Warp contact kernels."""
__version__ = "0.1.0"
