"""Refinement of files without levels (issue 43; data/io/volume_reduction.h, render/view_refinement.h):
a NIfTI written by nibabel, an HDF5 dataset written by h5py and a TIFF stack written by tifffile, each
over the memory budget, open reduced; a close view's full frame reads a box of the file itself where
the camera looks and is the frame of the file held whole in memory, where the reduced volume alone is
far from it; --stats names the levels, and what the box holds stays within the budget."""
import json
import os
import re
import subprocess

import numpy as np
import pytest
from cli_outputs import held_bytes, read_pfm

CLI = os.environ.get("PENUMBRA_CLI", "penumbra")
SHAPE = (40, 72, 64)  # z, y, x


def blobs(seed):
    """Soft balls with fine ripples that the reduction smooths away (uint16)."""
    z, y, x = np.meshgrid(*(np.linspace(-1, 1, n) for n in SHAPE), indexing="ij")
    rng = np.random.default_rng(seed)
    field = np.zeros(SHAPE)
    for _ in range(5):
        c = rng.uniform(-0.6, 0.6, 3)
        field += np.exp(-((x - c[0]) ** 2 + (y - c[1]) ** 2 + (z - c[2]) ** 2) * rng.uniform(4, 12))
    field *= 1 + 0.25 * np.sin(40 * x) * np.sin(37 * y)
    return (field / field.max() * 4000).astype(np.uint16)


def write_nifti(path, data):
    nib = pytest.importorskip("nibabel")
    affine = np.array([[-0.5, 0, 0, 12.0], [0, 0.4, 0, -7.0], [0, 0, 0.6, 3.0], [0, 0, 0, 1]])  # x flipped
    nib.save(nib.Nifti1Image(np.ascontiguousarray(data.transpose(2, 1, 0)), affine), str(path))


def write_hdf5(path, data):
    h5py = pytest.importorskip("h5py")
    with h5py.File(str(path), "w") as f:
        f.create_dataset("scan/density", data=data, chunks=(8, 16, 16), compression="gzip")


def write_tiff(path, data):
    tifffile = pytest.importorskip("tifffile")
    tifffile.imwrite(str(path), data)


WRITERS = {"nii.gz": write_nifti, "h5": write_hdf5, "tif": write_tiff}


def bounds(path):
    out = subprocess.run([CLI, "info", str(path)], capture_output=True, text=True, timeout=120, check=True).stdout
    lo, hi = re.search(r"^bounds\s+\[([^\]]+)\]\s+\.\.\s+\[([^\]]+)\]", out, re.M).groups()
    return np.array(lo.split(), float), np.array(hi.split(), float)


def scene(path, budget=None, refine=True, shadows="none"):
    lo, hi = bounds(path)
    centre, size = (lo + hi) / 2, hi - lo
    # a close look at the middle: the reduced voxel spans several pixels there
    target = centre + np.array([0.1, -0.05, 0.0]) * size
    eye = target + np.array([0.15, 0.1, -1.0]) * size.max() * 1.3
    v = {"file": str(path), "step": 0.5, "jitter": False, "refine": refine,
         "transfer_function": {"points": [[0, 0.1, 0.2, 0.8, 0], [1200, 0.2, 0.5, 0.9, 0.0], [2000, 0.9, 0.6, 0.3, 0.08],
                                          [4000, 1.0, 0.95, 0.9, 0.5]]}}
    if str(path).endswith(".h5"):
        v["dataset"] = "scan/density"
    s = {"volumes": [v], "lights": [{"type": "directional", "direction": [-0.4, -1.0, -0.3]}],
         "shadows": {"technique": shadows},
         "camera": {"eye": eye.tolist(), "target": target.tolist(), "fov_deg": 14, "width": 80, "height": 64}}
    if budget:
        s["memory_budget"] = budget
    return s


def render(tmp_path, doc, name):
    scene_file, image, stats = tmp_path / f"{name}.json", tmp_path / f"{name}.pfm", tmp_path / f"{name}.stats.json"
    scene_file.write_text(json.dumps(doc))
    r = subprocess.run([CLI, "render", str(scene_file), "-o", str(image), "--stats", str(stats)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    return read_pfm(image), json.loads(stats.read_text())


@pytest.mark.parametrize("suffix", sorted(WRITERS))
def test_a_file_read_reduced_is_refined_from_the_file(suffix, tmp_path):
    path = tmp_path / f"blobs.{suffix}"
    WRITERS[suffix](path, blobs(3))
    whole = held_bytes(SHAPE, 2)
    budget = int(whole * 0.9)  # the file does not fit; 2× reduced (an eighth) does, with room for the box in view
    refined, stats = render(tmp_path, scene(path, budget=budget), "refined")
    opened_dims = stats["volumes"][0]["dims"]
    assert opened_dims == [(n + 1) // 2 for n in reversed(SHAPE)], opened_dims
    [r] = stats["refinement"]
    assert (r["opened_level"], r["level"]) == (1, 0), r
    assert r["read_bytes"] > 0 and 0 < r["held_bytes"] == r["loaded_bytes"]
    assert np.prod(r["dims"]) < np.prod(SHAPE)  # a box of the file, not all of it
    assert stats["memory_budget"]["held"] <= budget

    in_memory, in_memory_stats = render(tmp_path, scene(path), "in_memory")
    assert in_memory_stats["volumes"][0]["dims"] == list(reversed(SHAPE))
    opened, opened_stats = render(tmp_path, scene(path, budget=budget, refine=False), "opened")
    assert opened_stats.get("refinement", []) == []
    refined_error = np.abs(refined - in_memory).max()
    opened_error = np.abs(opened - in_memory).max()
    # the same voxels on the same lattice; the table spans the box's and the reduced volume's value
    # range, not the whole file's: not always bit for bit
    assert refined_error < 5e-3, refined_error
    assert opened_error > 5 * refined_error and opened_error > 0.05, (opened_error, refined_error)
    assert refined.std() > 0.05
