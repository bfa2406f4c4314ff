"""penumbra's volume readers for the files scientists hand over (DICOM series, TIFF stacks, VTK image
data; src/penumbra/data/io/) against independent readers as oracles: pydicom for the DICOM CT (every
voxel, in Hounsfield units, in position order), tifffile for the confocal stacks (every voxel of every
channel), and penumbra's own NRRD reader for the VTK files VTK wrote from the same voxels. Then each
format opened end to end: `penumbra info` describes it and `penumbra render FILE` draws it.

    PYTHONPATH=build/release/python PENUMBRA_CLI=build/release/penumbra /usr/bin/python3 -m pytest -q tests/python/test_volume_formats.py
"""
import json
import os
import shutil
import subprocess

import numpy as np
import pytest

import penumbra
from cli_outputs import read_pfm

CLI = os.environ.get("PENUMBRA_CLI", "penumbra")
ROOT = os.environ.get("PENUMBRA_ROOT", os.path.join(os.path.dirname(__file__), "..", ".."))
DATA = os.environ.get("PENUMBRA_DATA_DIR", os.path.join(ROOT, "..", "shared", "data"))


def staged(name):
    path = os.path.join(DATA, name)
    if not os.path.exists(path):
        pytest.skip(f"missing data: {path} not found")
    return path


def pydicom_series(folder):
    """The slices in Hounsfield units, sorted by position along the slice normal, with their positions."""
    pydicom = pytest.importorskip("pydicom")
    slices = [pydicom.dcmread(os.path.join(folder, f)) for f in sorted(os.listdir(folder))]
    def along_normal(ds):
        o = np.array(ds.ImageOrientationPatient, dtype=float)
        return float(np.dot(np.cross(o[:3], o[3:]), np.array(ds.ImagePositionPatient, dtype=float)))
    slices.sort(key=along_normal)
    hu = np.stack([s.pixel_array.astype(np.float64) * float(s.RescaleSlope) + float(s.RescaleIntercept) for s in slices])
    return hu, slices


def test_dicom_series_equals_pydicom_in_hounsfield_units():
    folder = staged("dicom_pancreas_ct")
    v = penumbra.read_volume(folder)
    hu, slices = pydicom_series(folder)
    assert v.array.shape == (50, 512, 512)
    assert v.array.dtype == np.int16
    assert np.array_equal(v.array.astype(np.float64), hu)
    assert v.array.min() == -1000 and v.array.max() == 1365
    assert v.spacing == pytest.approx((3.0, 1.07421875, 1.07421875))  # (z, y, x), as the array
    first = [float(x) for x in slices[0].ImagePositionPatient]  # the lowest slice (patient LPS x, y, z; mm)
    assert v.origin == pytest.approx(tuple(reversed(first)), abs=1e-3)
    assert v.info["format"] == "dicom"
    assert len(v.info["series"]) == 1


def test_dicom_file_list_in_any_order_equals_the_folder(tmp_path):
    folder = staged("dicom_pancreas_ct")
    names = sorted(os.listdir(folder))
    rng = np.random.default_rng(7)
    shuffled = [os.path.join(folder, names[i]) for i in rng.permutation(len(names))]
    a = penumbra.read_volume(folder)
    b = penumbra.read_volume(shuffled)
    assert np.array_equal(a.array, b.array)
    with pytest.raises(penumbra.Error, match="missing slice between .*1-071.dcm.* and .*1-069.dcm"):  # named by its neighbours
        penumbra.read_volume([p for p in shuffled if not p.endswith("1-070.dcm")])


def test_tiff_stacks_equal_tifffile():
    tifffile = pytest.importorskip("tifffile")
    path = staged("arabidopsis_embryo.tif")
    v = penumbra.read_volume(path)
    assert np.array_equal(v.array, tifffile.imread(path))
    assert v.spacing == (1.0, 1.0, 1.0)
    path = staged("nucleus_conf_wf.tif")
    both = tifffile.imread(path)  # (z, c, y, x)
    assert both.shape == (45, 2, 130, 133)
    for c in range(2):
        v = penumbra.read_volume(path, channel=c)
        assert v.info["channels"] == 2 and v.info["channel"] == c
        assert np.array_equal(v.array, both[:, c])
    assert v.spacing == pytest.approx((0.4994126, 1 / 1.953591, 1 / 1.953591), rel=1e-5)
    with pytest.raises(penumbra.Error, match="channel"):
        penumbra.read_volume(path, channel=2)


@pytest.mark.parametrize("name", ["headsq_appended_raw.vti", "headsq_appended_zlib.vti", "headsq_vtkdefault.vti", "headsq.vtk"])
def test_vtk_image_data_equals_the_nrrd_it_was_written_from(name):
    reference = penumbra.read_volume(staged("headsq.nhdr"))
    v = penumbra.read_volume(staged(name))
    assert v.array.dtype == reference.array.dtype
    assert np.array_equal(v.array, reference.array)
    assert v.spacing == pytest.approx(reference.spacing)
    assert v.origin == pytest.approx(reference.origin)


def test_a_read_volume_goes_into_a_scene_as_is():
    v = penumbra.read_volume(staged("headsq_appended_zlib.vti"))
    scene = penumbra.Scene({"shadows": {"technique": "shadow_map"}})
    path = scene.add_volume(v.array, spacing=v.spacing, origin=v.origin)
    assert scene.to_dict()["volumes"][0]["spacing"] == pytest.approx([3.2, 3.2, 1.5])  # the scene file's (x, y, z)
    image = penumbra.Renderer(scene).render(width=48, height=32)
    assert np.asarray(image)[..., :3].std() > 0
    assert path == "volumes.0"


@pytest.mark.parametrize("name,needle", [
    ("dicom_pancreas_ct", "Hounsfield"),
    ("nucleus_conf_wf.tif", "channels"),
    ("headsq_vtkdefault.vti", "vti"),
])
def test_info_and_render_open_each_format(name, needle, tmp_path):
    path = staged(name)
    info = subprocess.run([CLI, "info", path], capture_output=True, text=True)
    assert info.returncode == 0, info.stderr
    assert needle in info.stdout
    out = tmp_path / "f.pfm"
    r = subprocess.run([CLI, "render", path, "-o", str(out), "--width", "96", "--height", "64"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert read_pfm(out).std() > 0.01, "the picture shows something"


def test_series_and_channel_options_reach_the_reader_and_are_refused_where_they_mean_nothing(tmp_path):
    tif = staged("nucleus_conf_wf.tif")
    r = subprocess.run([CLI, "info", tif, "--channel", "1"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "channel 1 loaded" in r.stdout and "608 .. 7480" in r.stdout  # channel 1's range (PROVENANCE.md)
    r = subprocess.run([CLI, "render", staged("headsq.nhdr"), "--channel", "1", "-o", str(tmp_path / "x.png")], capture_output=True, text=True)
    assert r.returncode != 0 and "--channel" in r.stderr
    assert not (tmp_path / "x.png").exists()
    r = subprocess.run([CLI, "render", tif, "--series", "0", "-o", str(tmp_path / "x.png")], capture_output=True, text=True)
    assert r.returncode != 0 and "--series" in r.stderr
    folder = staged("dicom_pancreas_ct")
    r = subprocess.run([CLI, "info", folder, "--series", "3"], capture_output=True, text=True)
    assert r.returncode != 0 and "1.3.6.1.4.1.14519.5.2.1.302382790855582445722435410442490497846" in r.stderr  # lists what exists
    scene = tmp_path / "scene.json"
    scene.write_text(json.dumps({"volumes": [{"file": tif, "channel": 1, "transfer_function": {"preset": "grayscale"}}],
                                 "camera": {"width": 32, "height": 32}}))
    r = subprocess.run([CLI, "render", str(scene), "-o", str(tmp_path / "s.png"), "--write-scene", str(tmp_path / "saved.json")],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    saved = json.loads((tmp_path / "saved.json").read_text())
    assert saved["volumes"][0]["channel"] == 1


def vdb_pair(tmp_path):
    """A .vdb with two grids (a fog of three balls far apart, a level-set sphere) written by pyopenvdb."""
    vdb = pytest.importorskip("pyopenvdb")
    fog = vdb.FloatGrid(0.0)
    fog.name = "density"
    acc = fog.getAccessor()
    for c in [(-20, 3, 0), (40, -9, 17), (5, 44, 60)]:
        for i in range(-5, 6):
            for j in range(-5, 6):
                for k in range(-5, 6):
                    r = (i * i + j * j + k * k) ** 0.5
                    if r < 5:
                        acc.setValueOn((c[0] + i, c[1] + j, c[2] + k), 1.0 - r / 5)
    fog.transform = vdb.createLinearTransform(voxelSize=0.25)
    sphere = vdb.createLevelSetSphere(radius=10.0, center=(1, 2, 3), voxelSize=0.5, halfWidth=3.0)
    sphere.name = "surface"
    path = str(tmp_path / "two.vdb")
    vdb.write(path, grids=[fog, sphere])
    return vdb, path, fog, sphere


def test_openvdb_grids_equal_pyopenvdb_dense_copies(tmp_path):
    vdb, path, fog, sphere = vdb_pair(tmp_path)
    for name, grid in [("density", fog), ("surface", sphere), (None, fog), (1, sphere)]:
        v = penumbra.read_volume(path, grid=name)
        lo, hi = grid.evalActiveVoxelBoundingBox()
        lo = [(c // 8) * 8 for c in lo]  # penumbra's grid starts at a leaf corner
        dims = [h - l + 1 for l, h in zip(lo, hi)]
        want = np.empty(dims, dtype=np.float32)
        want.fill(grid.background)
        grid.copyToArray(want, ijk=tuple(lo))
        assert v.array.shape == tuple(reversed(dims))
        np.testing.assert_array_equal(v.array, want.transpose(2, 1, 0))  # every voxel, (z, y, x)
        size = grid.transform.voxelSize()
        assert v.spacing == pytest.approx(tuple(reversed(size)))
        assert v.origin == pytest.approx(tuple(reversed(grid.transform.indexToWorld(tuple(lo)))))
        assert v.info["format"] == "vdb"
        assert any(n.startswith("sparse:") for n in v.info["notes"])
    with pytest.raises(penumbra.Error, match="no grid 'velocity'"):
        penumbra.read_volume(path, grid="velocity")


def test_openvdb_info_render_and_grid_option(tmp_path):
    _, path, _, _ = vdb_pair(tmp_path)
    r = subprocess.run([CLI, "info", path, "--grid", "surface"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "grid 'density': float, unknown class" in r.stdout or "grid 'density': float" in r.stdout
    assert "loaded grid 'surface'" in r.stdout and "level set" in r.stdout
    assert "sparse:" in r.stdout and "dense:" in r.stdout
    out = tmp_path / "fog.png"
    scene = tmp_path / "fog.json"
    r = subprocess.run([CLI, "render", path, "-o", str(out), "--width", "64", "--height", "48", "--write-scene", str(scene)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert out.stat().st_size > 0
    r = subprocess.run([CLI, "render", path, "--grid", "surface", "-o", str(out), "--width", "64", "--height", "48",
                        "--write-scene", str(scene)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert json.loads(scene.read_text())["volumes"][0]["grid"] == "surface"  # the choice survives --write-scene
    tif = staged("nucleus_conf_wf.tif")
    r = subprocess.run([CLI, "render", tif, "--grid", "density", "-o", str(out)], capture_output=True, text=True)
    assert r.returncode != 0 and "--grid" in r.stderr
    r = subprocess.run([CLI, "info", path, "--grid", "nothing"], capture_output=True, text=True)
    assert r.returncode != 0 and "no grid 'nothing'" in r.stderr and "density" in r.stderr
