"""A NumPy volume with soft shadows, edited and measured against the exact reference (docs/python.md).

    PYTHONPATH=build/release/python /usr/bin/python3 examples/python/numpy_volume.py [out.png]
"""
import sys

import numpy as np
import numpy.typing as npt

import penumbra


def blob(n: int) -> npt.NDArray[np.float32]:
    """A soft ball with a smaller, denser one inside: axes (z, y, x)."""
    z, y, x = np.mgrid[0:n, 0:n, 0:n].astype(np.float32) / (n - 1) - 0.5
    r = np.sqrt(x * x + y * y + z * z)
    outer = np.clip(1.0 - r / 0.45, 0, 1) * 0.5
    inner = np.clip(1.0 - np.sqrt((x - 0.1) ** 2 + y * y + z * z) / 0.15, 0, 1)
    return np.ascontiguousarray(np.maximum(outer, inner), dtype=np.float32)


def main(out: str) -> None:
    scene = penumbra.Scene({"shadows": {"technique": "cssm"}})
    volume = scene.add_volume(blob(64), spacing=1 / 64, origin=-0.5, transfer_function="viridis")
    scene.add_plane(point=(0, -0.55, 0), size=3)
    r = penumbra.Renderer(scene)
    r.set(volume + ".transfer_function", {"preset": "magma", "opacity_scale": 0.35})  # or just "magma"
    approximate = r.render(width=320, height=240, dtype="float32")
    r.set("shadows.technique", "ray_traced")
    exact = r.render(width=320, height=240, dtype="float32")
    error = penumbra.compare(approximate, exact)
    print(f"cssm against ray_traced: PSNR {error['psnr']:.1f} dB, default light {r.get('lights.0.direction')}")
    frame = r.render(width=320, height=240)
    mean_rgb: npt.NDArray[np.float64] = frame[..., :3].mean(axis=(0, 1))
    print("mean colour", np.round(mean_rgb, 1))
    with open(out, "wb") as f:
        f.write(frame._repr_png_() or b"")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "numpy_volume.png")
