"""The camera of data files opened directly (scene_io/data_scene.cpp complete_data_scene): framed by the
box's corners, not its bounding sphere, and, for a DICOM series, by the box of what its transfer
function shows, so that a CT fills the view instead of a third of it (issue 40). Checked on the scene
that `penumbra render --write-scene` saves: the box's corners all project inside the view and the
widest reaches near its edge."""
import json
import math
import os
import struct
import subprocess

import pytest

CLI = os.environ.get("PENUMBRA_CLI", "penumbra")
ROOT = os.environ.get("PENUMBRA_ROOT", os.path.join(os.path.dirname(__file__), "..", ".."))
DATA = os.environ.get("PENUMBRA_DATA_DIR", os.path.join(ROOT, "..", "shared", "data"))
FOV_DEG = 35  # the default camera's (scene/camera.h), square at 512 x 512


def saved_camera(inputs, tmp_path):
    scene = tmp_path / "scene.json"
    subprocess.run([CLI, "render", *inputs, "-o", str(tmp_path / "out.png"), "--set", "camera.width=32", "--set",
                    "camera.height=32", "--write-scene", str(scene)], check=True, capture_output=True)
    return json.loads(scene.read_text())["camera"]


def norm(v):
    n = math.sqrt(sum(x * x for x in v))
    return [x / n for x in v]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def extent_in_view(camera, lo, hi):
    """The largest |x|, |y| of the box's corners on the image plane, in units of the half view."""
    w = norm(camera["direction"])
    u = norm(cross(camera.get("up", [0, 1, 0]), w))
    v = cross(w, u)
    target = camera["target"]
    eye = [t + d * camera["distance"] for t, d in zip(target, w)]
    t = math.tan(math.radians(FOV_DEG) / 2)
    widest = 0.0
    for k in range(8):
        corner = [hi[a] if k >> a & 1 else lo[a] for a in range(3)]
        d = [c - e for c, e in zip(corner, eye)]
        z = -sum(a * b for a, b in zip(d, w))
        assert z > 0, "a corner lies behind the eye"
        widest = max(widest, abs(sum(a * b for a, b in zip(d, u))) / (z * t), abs(sum(a * b for a, b in zip(d, v))) / (z * t))
    return widest


def test_a_flat_volume_is_framed_by_its_corners_not_its_sphere(tmp_path):
    nx, ny, nz = 64, 64, 4
    header = f"NRRD0004\ntype: float\ndimension: 3\nsizes: {nx} {ny} {nz}\nencoding: raw\nendian: little\n\n"
    voxels = [float((i * 7) % 13) for i in range(nx * ny * nz)]
    (tmp_path / "slab.nrrd").write_bytes(header.encode() + struct.pack(f"<{len(voxels)}f", *voxels))
    camera = saved_camera([str(tmp_path / "slab.nrrd")], tmp_path)
    lo, hi = [0, 0, 0], [nx - 1, ny - 1, nz - 1]
    assert camera["target"] == pytest.approx([(a + b) / 2 for a, b in zip(lo, hi)])
    radius = 0.5 * math.dist(lo, hi)
    assert camera["distance"] < 0.9 * radius / math.sin(math.radians(FOV_DEG) / 2), "framed by the sphere"
    assert 0.85 < extent_in_view(camera, lo, hi) <= 1.0, "the box does not fill the view, or leaves it"


def test_a_dicom_series_is_framed_by_what_its_transfer_function_shows(tmp_path):
    series = os.path.join(DATA, "dicom_pancreas_ct")
    if not os.path.isdir(series):
        pytest.skip(f"missing data: {series} not found")
    pydicom = pytest.importorskip("pydicom")
    np = pytest.importorskip("numpy")
    camera = saved_camera([series], tmp_path)
    slices = sorted((pydicom.dcmread(os.path.join(series, f)) for f in os.listdir(series)),
                    key=lambda s: float(s.ImagePositionPatient[2]))
    hu = np.stack([s.pixel_array.astype(np.int32) * float(s.RescaleSlope) + float(s.RescaleIntercept) for s in slices])
    # ct-bone is transparent up to 150 HU; the box of the voxels above, less 0.5% of them at each end
    shown = hu > 150
    origin = [float(x) for x in slices[0].ImagePositionPatient]
    spacing = [float(slices[0].PixelSpacing[1]), float(slices[0].PixelSpacing[0]),
               float(slices[1].ImagePositionPatient[2]) - float(slices[0].ImagePositionPatient[2])]
    lo, hi = [], []
    for axis, numpy_axis in ((0, 2), (1, 1), (2, 0)):
        counts = shown.sum(axis=tuple(a for a in range(3) if a != numpy_axis))
        total, cum = counts.sum(), np.cumsum(counts)
        first, last = int(np.searchsorted(cum, 0.005 * total, side="right")), int(np.searchsorted(cum, 0.995 * total))
        lo.append(origin[axis] + first * spacing[axis])
        hi.append(origin[axis] + last * spacing[axis])
    assert camera["target"] == pytest.approx([(a + b) / 2 for a, b in zip(lo, hi)], abs=2 * max(spacing))
    extent = extent_in_view(camera, lo, hi)
    assert 0.85 < extent <= 1.01, f"what shows spans {extent:.2f} of the half view"
    whole = 0.5 * math.dist([0, 0, 0], [512 * spacing[0], 512 * spacing[1], len(slices) * spacing[2]])
    assert camera["distance"] < 0.85 * whole / math.sin(math.radians(FOV_DEG) / 2), "framed by the whole field of view's sphere"


def test_a_zarr_store_is_framed_like_the_same_voxels_in_a_file(tmp_path):
    """A Zarr store is a folder but no DICOM series: its camera is y up and framed by its whole box, as the
    NRRD of the same voxels (a folder of DICOM slices is z up and framed by what it shows)."""
    np = pytest.importorskip("numpy")
    pytest.importorskip("zarr")
    z, y, x = 24, 40, 56
    k, j, i = np.ogrid[0:z, 0:y, 0:x]
    data = (((i - 20) ** 2 + (j - 18) ** 2 + (k - 12) ** 2 < 100) * 900 + 50).astype(np.uint16)
    nrrd = tmp_path / "ball.nrrd"
    with open(nrrd, "wb") as f:
        f.write((f"NRRD0004\ntype: ushort\ndimension: 3\nsizes: {x} {y} {z}\nspacings: 1 1 1\nencoding: raw\nendian: little\n\n").encode()
                + data.astype("<u2").tobytes())
    store = tmp_path / "ball.zarr"
    subprocess.run([CLI, "convert", str(nrrd), "-o", str(store)], check=True, capture_output=True)
    from_file = saved_camera([str(nrrd)], tmp_path)
    from_store = saved_camera([str(store), "--level", "0"], tmp_path)
    assert from_store.get("up", [0, 1, 0]) == pytest.approx([0, 1, 0]), from_store  # "up" is left out when y
    assert from_store.get("up") == from_file.get("up")
    for key in ("direction", "distance", "target"):
        assert from_store[key] == pytest.approx(from_file[key], abs=1e-4), (key, from_store, from_file)
