"""`penumbra convert IN -o OUT.zarr` (issue 43): any volume penumbra reads written as an OME-Zarr 0.4
pyramid that python3-zarr reads back voxel for voxel (level 0 the input's voxels, each next level the
2×2×2 block means computed here with NumPy), with the metadata the spec asks for; penumbra reads its
own output back; an existing output, a bad input or a bad option leave nothing behind."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

zarr = pytest.importorskip("zarr")  # Debian python3-zarr

import penumbra  # noqa: E402

CLI = os.environ.get("PENUMBRA_CLI", "penumbra")


def nrrd(path, array, spacing=(0.5, 0.75, 1.25), origin=(3.0, -2.0, 1.0)):
    """A raw little-endian NRRD of `array` (z, y, x), spacings and origin given x, y, z."""
    types = {np.dtype("uint8"): "uchar", np.dtype("int16"): "short", np.dtype("uint16"): "ushort", np.dtype("float32"): "float"}
    header = (f"NRRD0004\ntype: {types[array.dtype]}\ndimension: 3\nsizes: {array.shape[2]} {array.shape[1]} {array.shape[0]}\n"
              f"space: left-posterior-superior\nspace directions: ({spacing[0]},0,0) (0,{spacing[1]},0) (0,0,{spacing[2]})\n"
              f"space origin: ({origin[0]},{origin[1]},{origin[2]})\nencoding: raw\nendian: little\n\n")
    with open(path, "wb") as f:
        f.write(header.encode() + np.ascontiguousarray(array).astype(array.dtype.newbyteorder("<")).tobytes())


def mean_levels(a):
    """Means of the 2×2×2 blocks computed in one pass (the writer averages the up to 8 voxels at once)."""
    z, y, x = a.shape
    fz, fy, fx = (2 if n > 1 else 1 for n in a.shape)
    oz, oy, ox = (z + fz - 1) // fz, (y + fy - 1) // fy, (x + fx - 1) // fx
    pad = np.full((oz * fz, oy * fy, ox * fx), np.nan)
    pad[:z, :y, :x] = a
    blocks = pad.reshape(oz, fz, oy, fy, ox, fx)
    mean = np.nanmean(blocks, axis=(1, 3, 5))
    if np.issubdtype(a.dtype, np.integer):
        return np.floor(mean + 0.5).astype(a.dtype)
    return mean.astype(a.dtype)


@pytest.mark.parametrize("dtype", ["uint8", "int16", "uint16", "float32"])
def test_the_pyramid_reads_back_in_zarr(tmp_path, dtype):
    rng = np.random.default_rng(5)
    if dtype == "float32":
        data = rng.normal(0, 1, (21, 37, 45)).astype(dtype)
    else:
        info = np.iinfo(dtype)
        data = rng.integers(max(info.min, -2000), min(info.max, 4000), (21, 37, 45), endpoint=True).astype(dtype)
    src = tmp_path / "in.nrrd"
    nrrd(src, data)
    out = tmp_path / "out.zarr"
    r = subprocess.run([CLI, "convert", str(src), "-o", str(out), "--chunk", "16", "--unit", "millimeter"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    root = zarr.open_group(str(out), mode="r")
    ms = root.attrs["multiscales"][0]
    assert ms["version"] == "0.4" and [a["name"] for a in ms["axes"]] == ["z", "y", "x"]
    assert all(a["type"] == "space" and a["unit"] == "millimeter" for a in ms["axes"])
    paths = [d["path"] for d in ms["datasets"]]
    assert paths == ["0", "1", "2"]  # 45 -> 23 -> 12 (fits a 16-voxel chunk)
    expected = data
    spacing, origin = np.array([1.25, 0.75, 0.5]), np.array([1.0, -2.0, 3.0])  # z, y, x
    for level, d in enumerate(ms["datasets"]):
        if level > 0:
            expected = mean_levels(expected)
        np.testing.assert_array_equal(root[d["path"]][:], expected, err_msg=f"level {level}")
        scale = d["coordinateTransformations"][0]["scale"]
        translation = d["coordinateTransformations"][1]["translation"]
        factor = np.array([2.0 ** level] * 3)
        assert scale == pytest.approx(spacing * factor)
        assert translation == pytest.approx(origin + (factor - 1) / 2 * spacing)
        assert root[d["path"]].chunks == (16, 16, 16) and root[d["path"]].compressor.cname == "lz4"
    # penumbra reads its own output: the finest level is the input, placed where the input was
    back = penumbra.read_volume(str(out), level=0)
    np.testing.assert_array_equal(back.array, data)
    assert back.spacing == pytest.approx((1.25, 0.75, 0.5)) and back.origin == pytest.approx((1.0, -2.0, 3.0))


def test_a_dicom_folder_converts(tmp_path):
    ct = os.path.join(os.environ.get("PENUMBRA_ROOT", "."), "..", "shared", "data", "dicom_pancreas_ct")
    if not os.path.isdir(ct):
        pytest.skip("missing data: ../shared/data/dicom_pancreas_ct")
    out = tmp_path / "ct.zarr"
    r = subprocess.run([CLI, "convert", ct, "-o", str(out), "--codec", "zstd"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "4 levels" in r.stdout
    np.testing.assert_array_equal(zarr.open_group(str(out), mode="r")["0"][:], penumbra.read_volume(ct).array)


def test_failures_leave_nothing_behind(tmp_path):
    src = tmp_path / "in.nrrd"
    nrrd(src, np.arange(4 * 5 * 6, dtype=np.uint16).reshape(4, 5, 6))
    out = tmp_path / "out.zarr"
    out.mkdir()
    r = subprocess.run([CLI, "convert", str(src), "-o", str(out)], capture_output=True, text=True)
    assert r.returncode != 0 and "already exists" in r.stderr
    assert os.listdir(out) == []
    for args, message in (([str(tmp_path / "missing.nrrd")], "missing.nrrd"),
                          ([str(src), "--codec", "brotli"], "codec 'brotli'"),
                          ([str(src), "--chunk", "4"], "--chunk")):
        target = tmp_path / "new.zarr"
        r = subprocess.run([CLI, "convert", *args, "-o", str(target)], capture_output=True, text=True)
        assert r.returncode != 0 and message in r.stderr, r.stderr
        assert not target.exists()
    assert [p for p in os.listdir(tmp_path) if p.startswith(".")] == [], "no partial folder is left"


def peak_rss_mib(args):
    """Runs `args` in a fresh Python process of its own, so that RUSAGE_CHILDREN is that one command's
    peak resident memory; returns (CompletedProcess-like returncode, stdout, stderr, MiB)."""
    probe = ("import resource, subprocess, sys, json\n"
             "r = subprocess.run(sys.argv[1:], capture_output=True, text=True)\n"
             "print(json.dumps([r.returncode, r.stdout, r.stderr, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024]))\n")
    out = subprocess.run([sys.executable, "-c", probe, *map(str, args)], capture_output=True, text=True, check=True)
    return json.loads(out.stdout)


def test_an_nrrd_streams_in_bounded_memory(tmp_path):
    """A 160 MB NRRD is read a slab at a time: convert's peak memory over what the program takes for a tiny
    file stays far below the file's size (read whole first, it is above it), and the pyramid is still
    every voxel and every mean."""
    z, y, x = 200, 640, 640
    k, j, i = np.ogrid[0:z, 0:y, 0:x]
    data = ((i * 7 + j * 3 + k * 11) % 4093).astype(np.uint16)
    src = tmp_path / "big.nrrd"
    nrrd(src, data)
    out = tmp_path / "big.zarr"
    code, stdout, stderr, mib = peak_rss_mib([CLI, "convert", src, "-o", out, "--chunk", "16"])
    assert code == 0, stderr
    assert "(streamed)" in stdout
    tiny = tmp_path / "tiny.nrrd"
    nrrd(tiny, np.zeros((4, 4, 4), np.uint16))
    code, _, stderr, baseline = peak_rss_mib([CLI, "convert", tiny, "-o", tmp_path / "tiny.zarr"])
    assert code == 0, stderr
    file_mib = data.nbytes / 2**20
    # 16 MiB slabs and 1.34 rows of 16 slices of 640 x 640 x 2 bytes: about 34 MiB over the program itself
    assert mib - baseline < 0.35 * file_mib, f"convert peaked at {mib:.0f} MiB ({baseline:.0f} MiB for a tiny file) for a {file_mib:.0f} MiB file"
    root = zarr.open_group(str(out), mode="r")
    np.testing.assert_array_equal(root["0"][:], data)
    np.testing.assert_array_equal(root["1"][:], mean_levels(data))
    # a pyramid converts again (rechunked, recompressed) from its level 0, streamed
    again = tmp_path / "again.zarr"
    code, stdout, stderr, _ = peak_rss_mib([CLI, "convert", out, "-o", again, "--chunk", "32", "--codec", "zstd"])
    assert code == 0, stderr
    assert "from zarr (streamed)" in stdout
    np.testing.assert_array_equal(zarr.open_group(str(again), mode="r")["0"][:], data)


def test_a_procedural_ct_body_streams(tmp_path):
    """--procedural ct-body is made a slab at a time (tests/test_procedural.cpp: each slab is the whole
    volume's slices byte for byte) on its documented grid; bad specs are errors that leave nothing."""
    out = tmp_path / "body.zarr"
    spec = '{"name": "ct-body", "dims": [40, 36, 90], "seed": 3}'
    r = subprocess.run([CLI, "convert", "--procedural", spec, "-o", str(out), "--chunk", "16"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "procedural ct-body (streamed)" in r.stdout
    back = penumbra.read_volume(str(out), level=0)
    assert back.array.shape == (90, 36, 40) and back.array.dtype == np.uint16
    assert back.spacing == pytest.approx((1734 / 90, 500 / 36, 500 / 40))  # z, y, x: a 500 x 500 x 1734 mm box
    assert back.origin == pytest.approx((-0.5 * 89 * 1734 / 90, -0.5 * 35 * 500 / 36, -0.5 * 39 * 500 / 40))
    assert np.median(back.array[:, 0, :]) < 200 and back.array.max() > 1400  # air at the border, bone inside
    for spec, message in (('{"name": "ct-body", "dims": [4, 4, 4]}', "dims"), ('{"name": "ct-body", "size": 8}', "size"),
                          ("not json", "--procedural"), ('{"name": "nothing"}', "nothing")):
        target = tmp_path / "bad.zarr"
        r = subprocess.run([CLI, "convert", "--procedural", spec, "-o", str(target)], capture_output=True, text=True)
        assert r.returncode != 0 and message in r.stderr, r.stderr
        assert not target.exists()
    r = subprocess.run([CLI, "convert", "-o", str(tmp_path / "none.zarr")], capture_output=True, text=True)
    assert r.returncode != 0 and "one input" in r.stderr


def test_an_hdf5_dataset_streams_a_hyperslab_at_a_time(tmp_path):
    """A 160 MB channel of a chunked, gzip-compressed 4-D HDF5 dataset (c z y x, written by h5py) is read a
    slab of slices at a time (hyperslabs whose chunk rows straddle the slabs): convert's peak memory over
    what a tiny file takes stays far below the channel's size, and the pyramid is still every voxel of
    that channel as h5py reads it, and every mean."""
    h5py = pytest.importorskip("h5py")  # Debian python3-h5py
    z, y, x = 200, 640, 640
    k, j, i = np.ogrid[0:z, 0:y, 0:x]
    channel1 = ((i * 5 + j * 3 + k * 13) % 4091).astype(np.uint16)
    src = tmp_path / "big.h5"
    with h5py.File(src, "w") as f:
        d = f.create_dataset("cells/raw", shape=(2, z, y, x), dtype="<u2", chunks=(1, 7, 128, 128), compression="gzip", compression_opts=1,
                             fillvalue=7)
        for first in range(0, z, 7):  # a chunk row at a time (h5py writing it whole rewrites chunks for minutes)
            d[1, first:first + 7] = channel1[first:first + 7]
    out = tmp_path / "big.zarr"
    code, stdout, stderr, mib = peak_rss_mib([CLI, "convert", src, "--channel", "1", "-o", out, "--chunk", "16"])
    assert code == 0, stderr
    assert "from hdf5 (streamed)" in stdout, stdout
    tiny = tmp_path / "tiny.h5"
    with h5py.File(tiny, "w") as f:
        f.create_dataset("v", data=np.zeros((4, 4, 4), np.uint16))
    code, _, stderr, baseline = peak_rss_mib([CLI, "convert", tiny, "-o", tmp_path / "tiny.zarr"])
    assert code == 0, stderr
    channel_mib = channel1.nbytes / 2**20
    assert mib - baseline < 0.35 * channel_mib, f"convert peaked at {mib:.0f} MiB ({baseline:.0f} MiB for a tiny file) for a {channel_mib:.0f} MiB channel"
    root = zarr.open_group(str(out), mode="r")
    with h5py.File(src, "r") as f:
        np.testing.assert_array_equal(root["0"][:], f["cells/raw"][1])
    np.testing.assert_array_equal(root["1"][:], mean_levels(channel1))


def test_a_tiff_stack_streams_a_slab_of_pages_at_a_time(tmp_path):
    """A 131 MB channel of a two-channel ImageJ hyperstack written by tifffile is decoded a slab of pages
    at a time: convert's peak memory over what a tiny stack takes stays far below the channel's size,
    and the pyramid is that channel as tifffile reads it, and every mean."""
    tifffile = pytest.importorskip("tifffile")  # Debian python3-tifffile
    z, y, x = 160, 640, 640
    k, j, i = np.ogrid[0:z, 0:y, 0:x]
    channel1 = ((i * 5 + j * 3 + k * 13) % 4091).astype(np.uint16)
    src = tmp_path / "big.tif"
    tifffile.imwrite(src, np.stack([4090 - channel1, channel1], axis=1), imagej=True, metadata={"axes": "ZCYX"})
    out = tmp_path / "big.zarr"
    code, stdout, stderr, mib = peak_rss_mib([CLI, "convert", src, "--channel", "1", "-o", out, "--chunk", "16"])
    assert code == 0, stderr
    assert "from tiff (streamed)" in stdout, stdout
    tiny = tmp_path / "tiny.tif"
    tifffile.imwrite(tiny, np.zeros((4, 2, 4, 4), np.uint16), imagej=True, metadata={"axes": "ZCYX"})
    code, _, stderr, baseline = peak_rss_mib([CLI, "convert", tiny, "--channel", "1", "-o", tmp_path / "tiny.zarr"])
    assert code == 0, stderr
    channel_mib = channel1.nbytes / 2**20
    assert mib - baseline < 0.35 * channel_mib, f"convert peaked at {mib:.0f} MiB ({baseline:.0f} MiB for a tiny stack) for a {channel_mib:.0f} MiB channel"
    root = zarr.open_group(str(out), mode="r")
    np.testing.assert_array_equal(root["0"][:], tifffile.imread(src)[:, 1])
    np.testing.assert_array_equal(root["1"][:], mean_levels(channel1))


def test_a_nifti_streams_a_slab_at_a_time(tmp_path):
    """A 164 MB gzip NIfTI written by nibabel whose affine reverses z (and y, in LPS) is decompressed up to
    each slab, whose slices come from the file's other end: convert's peak memory stays far below the
    volume's size, and the pyramid is nibabel's voxels placed in LPS, and every mean."""
    nib = pytest.importorskip("nibabel")  # Debian python3-nibabel
    z, y, x = 200, 640, 640
    k, j, i = np.ogrid[0:z, 0:y, 0:x]
    data = ((i * 5 + j * 3 + k * 13) % 4091 - 2000).astype(np.int16)
    src = tmp_path / "big.nii.gz"
    nib.save(nib.Nifti1Image(data.transpose(2, 1, 0), np.diag([-0.5, 0.5, -1.5, 1.0])), src)
    out = tmp_path / "big.zarr"
    code, stdout, stderr, mib = peak_rss_mib([CLI, "convert", src, "-o", out, "--chunk", "16"])
    assert code == 0, stderr
    assert "from nifti (streamed)" in stdout, stdout
    tiny = tmp_path / "tiny.nii.gz"
    nib.save(nib.Nifti1Image(np.zeros((4, 4, 4), np.int16), np.diag([-0.5, 0.5, -1.5, 1.0])), tiny)
    code, _, stderr, baseline = peak_rss_mib([CLI, "convert", tiny, "-o", tmp_path / "tiny.zarr"])
    assert code == 0, stderr
    file_mib = data.nbytes / 2**20
    assert mib - baseline < 0.35 * file_mib, f"convert peaked at {mib:.0f} MiB ({baseline:.0f} MiB for a tiny file) for a {file_mib:.0f} MiB volume"
    placed = np.asarray(nib.load(src).dataobj).transpose(2, 1, 0)[::-1, ::-1, :]  # RAS (-x, +y, -z) is LPS (+x, -y, -z)
    root = zarr.open_group(str(out), mode="r")
    np.testing.assert_array_equal(root["0"][:], placed)
    np.testing.assert_array_equal(root["1"][:], mean_levels(placed))


def legacy_vtk(path, array, spacing, components=1):
    """A BINARY legacy VTK STRUCTURED_POINTS file of `array` (z, y, x), laid out as VTK's
    vtkStructuredPointsWriter writes one: header lines, then big-endian values, the components of a point
    together (the others here the first negated)."""
    z, y, x = array.shape
    values = np.stack([array] + [-array] * (components - 1), axis=-1) if components > 1 else array
    header = (f"# vtk DataFile Version 5.1\nvtk output\nBINARY\nDATASET STRUCTURED_POINTS\nDIMENSIONS {x} {y} {z}\n"
              f"SPACING {spacing[0]} {spacing[1]} {spacing[2]}\nORIGIN 0 0 0\nPOINT_DATA {x * y * z}\n"
              f"SCALARS ImageFile short {components}\nLOOKUP_TABLE default\n")
    with open(path, "wb") as f:
        f.write(header.encode() + np.ascontiguousarray(values).astype(">i2").tobytes())


def test_a_legacy_vtk_file_streams_a_slab_at_a_time(tmp_path):
    """A 131 MB BINARY legacy VTK file whose negative z spacing reverses its slices is read a slab at a
    time, each slab's values sought from the file's other end: convert's peak memory stays far below its
    size, and the pyramid is the file's first component with z reversed, and every mean."""
    z, y, x = 160, 640, 640
    k, j, i = np.ogrid[0:z, 0:y, 0:x]
    data = ((i * 5 + j * 3 + k * 13) % 4091 - 2000).astype(np.int16)
    src = tmp_path / "big.vtk"
    legacy_vtk(src, data, (0.5, 0.5, -1.5))
    out = tmp_path / "big.zarr"
    code, stdout, stderr, mib = peak_rss_mib([CLI, "convert", src, "-o", out, "--chunk", "16"])
    assert code == 0, stderr
    assert "from vtk (streamed)" in stdout, stdout
    tiny = tmp_path / "tiny.vtk"
    legacy_vtk(tiny, np.zeros((4, 4, 4), np.int16), (0.5, 0.5, -1.5))
    code, _, stderr, baseline = peak_rss_mib([CLI, "convert", tiny, "-o", tmp_path / "tiny.zarr"])
    assert code == 0, stderr
    file_mib = data.nbytes / 2**20
    assert mib - baseline < 0.35 * file_mib, f"convert peaked at {mib:.0f} MiB ({baseline:.0f} MiB for a tiny file) for a {file_mib:.0f} MiB volume"
    placed = data[::-1]
    root = zarr.open_group(str(out), mode="r")
    np.testing.assert_array_equal(root["0"][:], placed)
    np.testing.assert_array_equal(root["1"][:], mean_levels(placed))
    # Two components: the first is the volume, read from every point's pair.
    two = tmp_path / "two.vtk"
    legacy_vtk(two, data[:40, :64, :96], (1, 1, 1), components=2)
    code, stdout, stderr, _ = peak_rss_mib([CLI, "convert", two, "-o", tmp_path / "two.zarr", "--chunk", "16"])
    assert code == 0, stderr
    np.testing.assert_array_equal(zarr.open_group(str(tmp_path / "two.zarr"), mode="r")["0"][:], data[:40, :64, :96])


def test_a_dicom_series_streams_a_slab_of_slices_at_a_time(tmp_path):
    """A 200-slice CT series (a real slice's header written by pydicom with new pixels and positions, the
    columns running posterior to anterior so that the slices come from the series' other end) is decoded
    a slab of slices at a time: convert's peak memory stays far below the series' size and the pyramid is
    the series read whole. With 16 stored bits the rescaled values might not fit int16: the type is then
    not known from the headers, and the series is read whole, with the same voxels."""
    pydicom = pytest.importorskip("pydicom")
    ct = os.path.join(os.environ.get("PENUMBRA_ROOT", "."), "..", "shared", "data", "dicom_pancreas_ct", "1-045.dcm")
    if not os.path.isfile(ct):
        pytest.skip("missing data: ../shared/data/dicom_pancreas_ct")
    z, y, x = 200, 512, 512
    j, i = np.ogrid[0:y, 0:x]

    def series(folder, bits_stored, slices=z):
        folder.mkdir()
        ds = pydicom.dcmread(ct)
        ds.file_meta.TransferSyntaxUID = pydicom.uid.ExplicitVRLittleEndian
        ds.BitsStored, ds.HighBit = bits_stored, bits_stored - 1
        ds.ImageOrientationPatient = [1, 0, 0, 0, -1, 0]  # normal -z: sorted along it, the slices run downwards
        for k in range(slices):
            ds.PixelData = ((i * 5 + j * 3 + k * 13) % 4091).astype("<u2").tobytes()
            ds.ImagePositionPatient = [-275, 100, 300 - 1.25 * k]
            ds.InstanceNumber = k + 1
            ds.SOPInstanceUID = pydicom.uid.generate_uid()
            ds.save_as(str(folder / f"slice{(k * 37) % slices:03d}.dcm"), write_like_original=False)  # files not in position order
        return folder

    twelve = series(tmp_path / "twelve", 12)
    out = tmp_path / "twelve.zarr"
    code, stdout, stderr, mib = peak_rss_mib([CLI, "convert", twelve, "-o", out, "--chunk", "16"])
    assert code == 0, stderr
    assert "from dicom (streamed)" in stdout, stdout
    small = series(tmp_path / "small", 12, slices=4)
    code, _, stderr, baseline = peak_rss_mib([CLI, "convert", small, "-o", tmp_path / "small.zarr"])
    assert code == 0, stderr
    series_mib = z * y * x * 2 / 2**20
    assert mib - baseline < 0.35 * series_mib, f"convert peaked at {mib:.0f} MiB ({baseline:.0f} MiB for 4 slices) for a {series_mib:.0f} MiB series"
    whole = penumbra.read_volume(str(twelve)).array
    assert whole.dtype == np.int16
    root = zarr.open_group(str(out), mode="r")
    np.testing.assert_array_equal(root["0"][:], whole)
    np.testing.assert_array_equal(root["1"][:], mean_levels(whole))
    sixteen = series(tmp_path / "sixteen", 16)
    r = subprocess.run([CLI, "convert", str(sixteen), "-o", str(tmp_path / "sixteen.zarr")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "from dicom (read whole)" in r.stdout, r.stdout
    np.testing.assert_array_equal(zarr.open_group(str(tmp_path / "sixteen.zarr"), mode="r")["0"][:], whole)
