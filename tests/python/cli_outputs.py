"""What penumbra writes and holds, read back for the tests: PFM frames, and the bytes a volume holds
under the memory budget (volume_held_bytes in src/penumbra/data/volume.h)."""
import numpy as np


def read_pfm(path):
    """A PFM frame as (height, width, 3) float32, rows top to bottom (PFM stores them bottom to top)."""
    with open(path, "rb") as f:
        assert f.readline().strip() == b"PF"
        w, h = map(int, f.readline().split())
        scale = float(f.readline())
        data = np.frombuffer(f.read(), dtype="<f4" if scale < 0 else ">f4").reshape(h, w, 3)
    return data[::-1]


def held_bytes(shape, itemsize):
    """volume_held_bytes: the voxels and 9 bytes per macrocell of 8 cells (max(1, ceil((n - 1) / 8)) per axis)."""
    cells = int(np.prod([max(1, (n - 1 + 7) // 8) for n in shape]))
    return int(np.prod(shape)) * itemsize + 9 * cells
