"""Test volumes for the reader oracles (test_zarr_oracle.py, test_hdf5_oracle.py): a smooth field with
noise, so that chunk edges, byte orders and axis orders all show in the voxels."""
import numpy as np


def field(shape, dtype, seed=1):
    """(z, y, x) voxels of `dtype`: sin·cos across x and y, a ramp along z, Gaussian noise; integers
    spread over the dtype's range (clipped to -30000..60000)."""
    rng = np.random.default_rng(seed)
    z, y, x = np.meshgrid(*(np.linspace(0, 1, n) for n in shape), indexing="ij")
    base = np.sin(6 * x) * np.cos(4 * y) + z + rng.normal(0, 0.05, shape)
    if np.issubdtype(np.dtype(dtype), np.integer):
        info = np.iinfo(dtype)
        lo, hi = max(info.min, -30000), min(info.max, 60000)
        return (lo + (base - base.min()) / (np.ptp(base) or 1) * (hi - lo)).astype(dtype)
    return base.astype(dtype)
