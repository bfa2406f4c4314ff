"""The scene's memory_budget and `penumbra render --memory-budget` (issue 43): an OME-Zarr pyramid opens at
the finest level whose voxels and macrocells fit (volume_held_bytes: 9 bytes per macrocell of 8³ voxels), gradients are stored only where they fit too, the frame is the frame of that level opened by
hand, peak memory follows the budget, and what cannot fit is an error that names the budget."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

zarr = pytest.importorskip("zarr")  # Debian python3-zarr

import penumbra  # noqa: E402
from cli_outputs import held_bytes  # noqa: E402

CLI = os.environ.get("PENUMBRA_CLI", "penumbra")


def nrrd(path, array):
    header = (f"NRRD0004\ntype: ushort\ndimension: 3\nsizes: {array.shape[2]} {array.shape[1]} {array.shape[0]}\n"
              f"spacings: 1 1 1\nencoding: raw\nendian: little\n\n")
    with open(path, "wb") as f:
        f.write(header.encode() + np.ascontiguousarray(array, dtype="<u2").tobytes())


def blobs(shape):
    """Two soft balls: a volume with an inside and an outside at every level of the pyramid."""
    z, y, x = np.meshgrid(*(np.linspace(-1, 1, n) for n in shape), indexing="ij")
    field = np.exp(-((x - 0.3) ** 2 + y ** 2 + z ** 2) * 6) + 0.7 * np.exp(-((x + 0.4) ** 2 + (y - 0.2) ** 2 + z ** 2) * 10)
    return (field * 3000).astype(np.uint16)


@pytest.fixture(scope="module")
def pyramid(tmp_path_factory):
    folder = tmp_path_factory.mktemp("budget")
    src = folder / "blobs.nrrd"
    nrrd(src, blobs((80, 96, 128)))
    out = folder / "blobs.zarr"
    r = subprocess.run([CLI, "convert", str(src), "-o", str(out), "--chunk", "16"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    shapes = [zarr.open_group(str(out), mode="r")[str(level)].shape for level in range(4)]
    assert shapes == [(80, 96, 128), (40, 48, 64), (20, 24, 32), (10, 12, 16)]
    return src, out, shapes


def render(tmp_path, *args, name="out"):
    image, stats = tmp_path / f"{name}.png", tmp_path / f"{name}.json"
    r = subprocess.run([CLI, "render", *map(str, args), "--width", "96", "--height", "72", "-o", str(image), "--stats", str(stats)],
                       capture_output=True, text=True, timeout=300)
    return r, image, (json.loads(stats.read_text()) if stats.exists() else None)


def test_the_finest_level_that_fits_opens(pyramid, tmp_path):
    _, store, shapes = pyramid
    for level in (0, 1, 2, 3):
        budget = held_bytes(shapes[level], 2)  # exactly what the level holds: it fits, the finer one does not
        r, _, stats = render(tmp_path, store, "--memory-budget", budget, name=f"l{level}")
        assert r.returncode == 0, r.stderr
        assert stats["volumes"][0]["dims"] == list(reversed(shapes[level])), f"budget {budget}"
        assert stats["memory_budget"]["budget"] == budget
        # no room left for 4 bytes a voxel of gradients: they are computed per sample
        assert stats["memory_budget"]["held"] <= budget
        assert stats["memory_bytes"]["volume_structures"] < 4 * np.prod(shapes[level])


def test_gradients_are_stored_where_they_fit(pyramid, tmp_path):
    _, store, shapes = pyramid
    budget = held_bytes(shapes[1], 2) + 4 * int(np.prod(shapes[1]))
    r, _, stats = render(tmp_path, store, "--memory-budget", budget)
    assert r.returncode == 0, r.stderr
    assert stats["volumes"][0]["dims"] == list(reversed(shapes[1]))
    assert stats["memory_bytes"]["volume_structures"] >= 4 * np.prod(shapes[1])
    assert stats["memory_budget"]["held"] <= budget


def test_the_frame_is_the_levels_frame(pyramid, tmp_path):
    """Under a budget the frame is exactly the frame of the level it chose, opened by hand (gradients on
    the fly in both: the budget leaves no room for them)."""
    _, store, shapes = pyramid
    r, budgeted, stats = render(tmp_path, store, "--memory-budget", held_bytes(shapes[2], 2) + 100, name="budget")
    assert r.returncode == 0, r.stderr
    r, by_hand, _ = render(tmp_path, store, "--level", 2, "--set", "volumes.0.gradients=on_the_fly", name="level")
    assert r.returncode == 0, r.stderr
    assert budgeted.read_bytes() == by_hand.read_bytes()
    r, finest, _ = render(tmp_path, store, "--level", 0, name="finest")
    assert r.returncode == 0, r.stderr
    assert budgeted.read_bytes() != finest.read_bytes()


def test_what_cannot_fit_is_an_error(pyramid, tmp_path):
    src, store, shapes = pyramid
    r, image, _ = render(tmp_path, store, "--memory-budget", "1K")
    assert r.returncode != 0 and "no level of the pyramid fits the memory budget (1 KiB)" in r.stderr, r.stderr
    assert not image.exists()
    # a file without a pyramid opens reduced (test_a_file_over_its_budget_opens_reduced), down to one voxel
    # along its longest axis: under 10 bytes not even that fits
    r, image, _ = render(tmp_path, src, "--memory-budget", "10")
    assert r.returncode != 0 and "blobs.nrrd" in r.stderr and "even reduced to one voxel" in r.stderr and "10 B" in r.stderr, r.stderr
    assert not image.exists()
    r, _, _ = render(tmp_path, store, "--memory-budget", "lots")
    assert r.returncode != 0 and "--memory-budget" in r.stderr and "'lots'" in r.stderr, r.stderr
    # asked for explicitly, stored gradients that do not fit are an error too
    r, _, _ = render(tmp_path, store, "--memory-budget", held_bytes(shapes[1], 2), "--set", "volumes.0.gradients=stored")
    assert r.returncode != 0 and "gradients" in r.stderr and "memory_budget" in r.stderr, r.stderr


def test_the_scene_key(pyramid, tmp_path):
    _, store, shapes = pyramid
    for budget in (held_bytes(shapes[2], 2), f"{-(-held_bytes(shapes[2], 2) // 1024)}K"):
        scene = tmp_path / "scene.json"
        scene.write_text(json.dumps({"memory_budget": budget, "volumes": [{"file": str(store)}]}))
        r, _, stats = render(tmp_path, scene)
        assert r.returncode == 0, r.stderr
        assert stats["volumes"][0]["dims"] == list(reversed(shapes[2])), budget
    for bad in (-5, 0, "4X", [1]):
        scene.write_text(json.dumps({"memory_budget": bad, "volumes": [{"file": str(store)}]}))
        r, _, _ = render(tmp_path, scene)
        assert r.returncode != 0 and "memory_budget" in r.stderr, (bad, r.stderr)
    # two volumes share one budget, in order: the second opens coarser once the first took its part
    scene.write_text(json.dumps({"memory_budget": held_bytes(shapes[1], 2) + held_bytes(shapes[2], 2),
                                 "volumes": [{"file": str(store)}, {"file": str(store)}]}))
    r, _, stats = render(tmp_path, scene)
    assert r.returncode == 0, r.stderr
    assert [v["dims"] for v in stats["volumes"]] == [list(reversed(shapes[1])), list(reversed(shapes[2]))]


def test_read_volume_takes_the_budget(pyramid):
    _, store, shapes = pyramid
    v = penumbra.read_volume(str(store), memory_budget=held_bytes(shapes[1], 2))
    assert v.array.shape == shapes[1]
    assert any("memory budget" in n for n in v.info["notes"])
    with pytest.raises(penumbra.Error, match="memory size 'x'"):
        penumbra.read_volume(str(store), memory_budget="x")


def peak_rss_mib(args):
    probe = ("import resource, subprocess, sys\n"
             "r = subprocess.run(sys.argv[1:], capture_output=True, text=True)\n"
             "assert r.returncode == 0, r.stderr\n"
             "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024)\n")
    out = subprocess.run([sys.executable, "-c", probe, *map(str, args)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return float(out.stdout)


def test_peak_memory_follows_the_budget(tmp_path):
    """A 64 MiB level 0 (256³ uint16; with its stored gradients 192 MiB): rendered under a 4 MiB budget the
    process peaks within the budget plus 8 MiB of what it holds when it opens the coarsest level by hand."""
    k, j, i = np.ogrid[0:256, 0:256, 0:256]
    src = tmp_path / "cube.nrrd"
    nrrd(src, ((i * 5 + j * 3 + k * 7) % 3001).astype(np.uint16))
    store = tmp_path / "cube.zarr"
    r = subprocess.run([CLI, "convert", str(src), "-o", str(store), "--chunk", "32"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    os.remove(src)
    common = ["render", store, "--width", "64", "--height", "48", "-o", tmp_path / "x.png"]
    coarsest = peak_rss_mib([CLI, *common, "--level", 3])
    budgeted = peak_rss_mib([CLI, *common, "--memory-budget", "4M"])
    finest = peak_rss_mib([CLI, *common, "--level", 0])
    assert budgeted <= coarsest + 4 + 8, (coarsest, budgeted, finest)
    assert finest > coarsest + 64, (coarsest, budgeted, finest)  # the check can see a level that does not fit


def test_every_level_shows_the_same_matter(tmp_path):
    """A translucent box (alpha 0.04 per voxel of the data at full resolution) looks the same from level 0
    and level 1: opacities refer to the finest level's voxel (Volume::opacity_length), not the level's own,
    which would halve the box's optical thickness (transmittance 0.96^16 = 0.52 against 0.96^32 = 0.27)."""
    data = np.zeros((64, 64, 64), np.uint16)
    data[16:48, 16:48, 16:48] = 100  # edges on even voxels: level 1 holds the same box, crisp
    src = tmp_path / "box.nrrd"
    nrrd(src, data)
    store = tmp_path / "box.zarr"
    r = subprocess.run([CLI, "convert", str(src), "-o", str(store), "--chunk", "16"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    tf = {"points": [[0, 1, 1, 1, 0], [50, 1, 1, 1, 0], [60, 0.9, 0.6, 0.3, 0.04], [100, 0.9, 0.6, 0.3, 0.04]]}
    images = []
    for level in (0, 1):
        scene = {"volumes": [{"file": str(store), "level": level, "transfer_function": tf, "jitter": False}],
                 "shadows": {"technique": "none"}, "camera": {"eye": [31.5, 31.5, 200], "target": [31.5, 31.5, 31.5], "width": 64, "height": 64}}
        images.append(penumbra.Renderer(scene).render(dtype="float32"))
    centre = [img[24:40, 24:40, :3].mean() for img in images]
    # within one boundary sample (level 1 steps a level-0 voxel at a time: one sample of alpha 0.04 more
    # or less is 4 %); with the level's own voxel as the reference the centre is 29 % darker
    assert centre[1] == pytest.approx(centre[0], rel=0.06), centre
    assert penumbra.compare(images[0], images[1])["rmse"] < 0.02


def block_means(a, f):
    """Means of the f×f×f blocks (fewer at the edges), integers rounded half up: the reduced file's voxels."""
    z, y, x = a.shape
    pad = np.full((-(-z // f) * f, -(-y // f) * f, -(-x // f) * f), np.nan)
    pad[:z, :y, :x] = a
    mean = np.nanmean(pad.reshape(pad.shape[0] // f, f, pad.shape[1] // f, f, pad.shape[2] // f, f), axis=(1, 3, 5))
    return np.floor(mean + 0.5).astype(a.dtype) if np.issubdtype(a.dtype, np.integer) else mean.astype(a.dtype)


def test_a_file_over_its_budget_opens_reduced(pyramid, tmp_path):
    """An NRRD and an HDF5 dataset over the budget open at the finest power-of-two reduction that fits, read
    a slab at a time, each voxel the mean of its block; placed as a pyramid's level (spacing × 2^l, the
    block's centre), the frame is byte for byte the frame of the pyramid's level 1 opened by hand."""
    src, store, shapes = pyramid
    data = blobs((80, 96, 128))
    for budget, f in ((held_bytes(shapes[1], 2), 2), (held_bytes(shapes[2], 2), 4), (held_bytes(shapes[1], 2) - 1, 4)):
        v = penumbra.read_volume(str(src), memory_budget=budget)
        np.testing.assert_array_equal(v.array, block_means(data, f))
        assert v.spacing == pytest.approx((f, f, f)) and v.origin == pytest.approx(((f - 1) / 2,) * 3)
        assert any(f"reduced {f}×" in n and "memory budget" in n for n in v.info["notes"]), v.info["notes"]
    assert penumbra.read_volume(str(src), memory_budget=held_bytes(shapes[0], 2)).array.shape == shapes[0]  # fits: whole
    h5py = pytest.importorskip("h5py")
    h5 = tmp_path / "blobs.h5"
    with h5py.File(h5, "w") as file:
        file.create_dataset("v", data=data, chunks=(7, 32, 32), compression="gzip")
    np.testing.assert_array_equal(penumbra.read_volume(str(h5), memory_budget=held_bytes(shapes[2], 2)).array, block_means(data, 4))
    # one scene but for its volume's file (a file's automatic scene depends on its format's metadata)
    def scene(name, volume):
        path = tmp_path / f"{name}.json"
        path.write_text(json.dumps({"volumes": [{"transfer_function": {"points": [[0, 0.9, 0.5, 0.3, 0], [800, 0.9, 0.6, 0.4, 0.05],
                                                                                   [3000, 1, 1, 1, 0.3]]}, **volume}],
                                    "camera": {"eye": [250, 160, 300], "target": [64, 48, 40], "fov_deg": 35},
                                    "lights": [{"type": "directional", "direction": [-0.4, -1, -0.3]}], "shadows": {"technique": "cssm"}}))
        return path
    r, reduced, stats = render(tmp_path, scene("reduced", {"file": str(src)}), "--memory-budget", held_bytes(shapes[1], 2), name="reduced")
    assert r.returncode == 0, r.stderr
    assert stats["volumes"][0]["dims"] == list(reversed(shapes[1]))
    r, level, _ = render(tmp_path, scene("level1", {"file": str(store), "level": 1, "gradients": "on_the_fly"}), name="level1")
    assert r.returncode == 0, r.stderr
    assert reduced.read_bytes() == level.read_bytes()
    r, whole, _ = render(tmp_path, scene("whole", {"file": str(src)}), name="whole")
    assert r.returncode == 0, r.stderr
    assert whole.read_bytes() != reduced.read_bytes()  # the comparison can see a volume that was not reduced


def test_a_file_over_its_budget_is_never_held_whole(tmp_path):
    """A 64 MiB NRRD (256³ uint16) under a 4 MiB budget: the process peaks within 16 MiB (a slab) and 8 MiB
    of rendering the reduced volume written as a file of its own, far below the file read whole."""
    k, j, i = np.ogrid[0:256, 0:256, 0:256]
    data = ((i * 5 + j * 3 + k * 7) % 3001).astype(np.uint16)
    src = tmp_path / "cube.nrrd"
    nrrd(src, data)
    small = tmp_path / "small.nrrd"
    nrrd(small, block_means(data, 4))
    common = ["render", "--width", "64", "--height", "48", "-o", tmp_path / "x.png"]
    alone = peak_rss_mib([CLI, *common, small])
    budgeted = peak_rss_mib([CLI, *common, src, "--memory-budget", "4M"])
    whole = peak_rss_mib([CLI, *common, src])
    assert budgeted <= alone + 16 + 8, (alone, budgeted, whole)
    assert whole > alone + 64, (alone, budgeted, whole)


def test_a_broken_file_over_its_budget_is_an_error_naming_it_once(tmp_path):
    """Read reduced, a truncated NRRD, a NaN voxel and an empty HDF5 file are the errors they are read whole,
    naming the file once; nothing is written."""
    short = tmp_path / "short.nrrd"
    short.write_bytes(b"NRRD0004\ntype: ushort\ndimension: 3\nsizes: 64 64 64\nencoding: raw\nendian: little\n\n" + bytes(40 * 64 * 64 * 2))
    nan = np.ones((16, 16, 16), np.float32)
    nan[3, 3, 3] = np.nan
    nan_file = tmp_path / "nan.nrrd"
    nan_file.write_bytes(b"NRRD0004\ntype: float\ndimension: 3\nsizes: 16 16 16\nencoding: raw\nendian: little\n\n" + nan.tobytes())
    empty = tmp_path / "empty.h5"
    empty.write_bytes(b"")
    for path, message in ((short, "raw data has only 327680 bytes"), (nan_file, "is NaN"), (empty, "not an HDF5 file")):
        r, image, _ = render(tmp_path, path, "--memory-budget", "4K", name=path.stem)
        assert r.returncode != 0 and message in r.stderr and r.stderr.count(str(path)) == 1, r.stderr
        assert not image.exists()


def test_tiff_and_nifti_over_their_budget_open_reduced(tmp_path):
    """A TIFF stack (a zlib-compressed ImageJ hyperstack written by tifffile, channel 1) and NIfTI files
    written by nibabel (gzip with z and y reversed by the affine, and plain with a scale slope) over the
    budget open reduced like an NRRD: each voxel the mean of its block of the placed voxels, the file
    read in two slabs of slices (26 MB a channel, 16 MiB slabs)."""
    tifffile = pytest.importorskip("tifffile")
    nib = pytest.importorskip("nibabel")
    shape = (200, 256, 256)  # z, y, x
    k, j, i = np.ogrid[0:shape[0], 0:shape[1], 0:shape[2]]
    data = ((i * 5 + j * 3 + k * 7) % 3001).astype(np.uint16)
    tif = tmp_path / "stack.tif"
    tifffile.imwrite(tif, np.stack([3000 - data, data], axis=1), imagej=True, metadata={"axes": "ZCYX"}, compression="zlib")
    f = 4
    reduced = tuple(-(-n // f) for n in shape)
    v = penumbra.read_volume(str(tif), channel=1, memory_budget=held_bytes(reduced, 2))
    np.testing.assert_array_equal(v.array, block_means(data, f))
    assert any(f"reduced {f}×" in n for n in v.info["notes"]) and v.info["format"] == "tiff", v.info
    signed = data.astype(np.int16) - 1000
    gz = tmp_path / "flipped.nii.gz"
    nib.save(nib.Nifti1Image(signed.transpose(2, 1, 0), np.diag([-2.0, 3.0, -4.0, 1.0])), gz)
    placed = signed[::-1, ::-1, :]  # RAS (-x, +y, -z) is LPS (+x, -y, -z): y and z reversed
    np.testing.assert_array_equal(penumbra.read_volume(str(gz)).array, placed)
    v = penumbra.read_volume(str(gz), memory_budget=held_bytes(reduced, 2))
    np.testing.assert_array_equal(v.array, block_means(placed, f))
    assert v.spacing == pytest.approx((4 * f, 3 * f, 2 * f)) and v.info["format"] == "nifti"
    scaled = nib.Nifti1Image(signed.transpose(2, 1, 0), np.diag([2.0, 3.0, 4.0, 1.0]))
    scaled.header.set_slope_inter(0.5, 10)
    plain = tmp_path / "scaled.nii"
    nib.save(scaled, plain)
    want = (signed.astype(np.float32) * 0.5 + 10)[:, ::-1, ::-1]  # RAS (+x, +y) is LPS (-x, -y)
    v = penumbra.read_volume(str(plain), memory_budget=held_bytes(reduced, 4))
    np.testing.assert_allclose(v.array, block_means(want, f), rtol=1e-6)


def test_a_dicom_series_over_its_budget_opens_reduced():
    """The staged CT series (50 slices of 512², two 16 MiB slabs) under a budget opens as the block means
    of the series read whole, decoding a slab of slices at a time."""
    ct = os.path.join(os.environ.get("PENUMBRA_ROOT", "."), "..", "shared", "data", "dicom_pancreas_ct")
    if not os.path.isdir(ct):
        pytest.skip("missing data: ../shared/data/dicom_pancreas_ct")
    whole = penumbra.read_volume(ct)
    f = 2
    v = penumbra.read_volume(ct, memory_budget=held_bytes(tuple(-(-n // f) for n in whole.array.shape), 2))
    np.testing.assert_array_equal(v.array, block_means(whole.array, f))
    assert v.info["format"] == "dicom" and any(f"reduced {f}×" in n for n in v.info["notes"]), v.info
    assert v.spacing == pytest.approx(tuple(s * f for s in whole.spacing), rel=1e-5)


def vti_zlib(path, array, spacing, block=50000):
    """A VTK XML ImageData file of `array` (z, y, x uint16) as vtkXMLImageDataWriter lays out raw appended
    data compressed by vtkZLibDataCompressor: a UInt32 header (blocks, block size, last block size, each
    block's compressed size), then the zlib blocks."""
    import zlib
    z, y, x = array.shape
    raw = np.ascontiguousarray(array).astype("<u2").tobytes()
    blocks = [zlib.compress(raw[b:b + block]) for b in range(0, len(raw), block)]
    last = len(raw) - (len(blocks) - 1) * block
    header = np.array([len(blocks), block, last if last < block else 0] + [len(b) for b in blocks], "<u4").tobytes()
    xml = (f'<?xml version="1.0"?>\n<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" header_type="UInt32" '
           f'compressor="vtkZLibDataCompressor">\n  <ImageData WholeExtent="0 {x - 1} 0 {y - 1} 0 {z - 1}" Origin="0 0 0" '
           f'Spacing="{spacing[0]} {spacing[1]} {spacing[2]}" Direction="1 0 0 0 1 0 0 0 1">\n'
           f'    <Piece Extent="0 {x - 1} 0 {y - 1} 0 {z - 1}">\n      <PointData Scalars="v">\n'
           f'        <DataArray type="UInt16" Name="v" format="appended" offset="0"/>\n      </PointData>\n'
           f'    </Piece>\n  </ImageData>\n  <AppendedData encoding="raw">\n   _')
    with open(path, "wb") as f:
        f.write(xml.encode() + header + b"".join(blocks) + b"\n  </AppendedData>\n</VTKFile>\n")


def test_vtk_image_data_over_its_budget_opens_reduced(tmp_path):
    """A BINARY legacy VTK file whose negative z spacing reverses its slices and a .vti of zlib blocks
    (50,000 bytes: cut by the slabs' ends) over the budget open reduced like an NRRD: each voxel the mean of its
    block of the placed voxels, the file read in two slabs of slices (26 MB, 16 MiB slabs)."""
    from test_convert import legacy_vtk
    shape = (200, 256, 256)  # z, y, x
    k, j, i = np.ogrid[0:shape[0], 0:shape[1], 0:shape[2]]
    data = ((i * 5 + j * 3 + k * 7) % 3001).astype(np.int16)
    f = 4
    reduced = tuple(-(-n // f) for n in shape)
    vtk = tmp_path / "reversed.vtk"
    legacy_vtk(vtk, data, (1.0, 2.0, -3.0))
    placed = data[::-1]
    np.testing.assert_array_equal(penumbra.read_volume(str(vtk)).array, placed)
    v = penumbra.read_volume(str(vtk), memory_budget=held_bytes(reduced, 2))
    np.testing.assert_array_equal(v.array, block_means(placed, f))
    assert any(f"reduced {f}×" in n for n in v.info["notes"]) and v.info["format"] == "vtk", v.info
    vti = tmp_path / "blocks.vti"
    vti_zlib(vti, data.astype(np.uint16), (1.0, 2.0, 3.0))
    np.testing.assert_array_equal(penumbra.read_volume(str(vti)).array, data.astype(np.uint16))
    v = penumbra.read_volume(str(vti), memory_budget=held_bytes(reduced, 2))
    np.testing.assert_array_equal(v.array, block_means(data.astype(np.uint16), f))
    assert v.info["format"] == "vti" and v.spacing == pytest.approx((f * 3.0, f * 2.0, f * 1.0))  # z, y, x


def test_a_vti_of_one_zlib_block_shorter_than_the_block_size_reads():
    """VTK writes an array smaller than its 32 KiB block size as one block whose (last) size is the
    array's: such a file was refused as lying about its size."""
    import tempfile
    data = (np.arange(16 * 16 * 16) % 3001).astype(np.uint16).reshape(16, 16, 16)
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "small.vti")
        vti_zlib(path, data, (1.0, 1.0, 1.0), block=1 << 15)
        np.testing.assert_array_equal(penumbra.read_volume(path).array, data)
