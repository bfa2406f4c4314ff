"""HDF5 volumes (issue 43, its second reader) written by h5py and read back by penumbra: every voxel as
h5py reads it, for contiguous and chunked datasets, gzip with and without shuffle, fletcher32,
scale-offset, unwritten chunks (the fill value), both byte orders and ten dtypes; a dataset chosen by
its path, a 4-D dataset's channel, element_size_um as the spacing; a file with several candidates
lists them, a filter libhdf5 lacks (h5py's lzf) is refused by name, a truncated file is refused."""
import os
import subprocess

import numpy as np
import pytest

h5py = pytest.importorskip("h5py")  # Debian python3-h5py (scripts/install-deps.sh)

import penumbra  # noqa: E402
from volume_fields import field  # noqa: E402


def write(path, name, data, **kwargs):
    with h5py.File(path, "w") as f:
        f.create_dataset(name, data=data, **kwargs)


@pytest.mark.parametrize("layout", [
    {}, {"chunks": (4, 8, 8)}, {"chunks": (5, 7, 9), "compression": "gzip", "compression_opts": 4},
    {"chunks": (4, 8, 8), "compression": "gzip", "shuffle": True}, {"chunks": (4, 8, 8), "fletcher32": True},
    {"chunks": (4, 8, 8), "scaleoffset": 0}])
def test_layouts_and_filters_read_as_h5py_reads(tmp_path, layout):
    data = field((11, 17, 19), "<u2")
    path = tmp_path / "a.h5"
    write(path, "volume", data, **layout)
    v = penumbra.read_volume(str(path))
    with h5py.File(path, "r") as f:
        np.testing.assert_array_equal(v.array, f["volume"][()])
    assert v.info["format"] == "hdf5" and v.array.dtype == np.uint16


@pytest.mark.parametrize("dtype, stored", [("|u1", np.uint8), ("<i2", np.int16), ("<u2", np.uint16), (">u2", np.uint16),
                                           ("<f4", np.float32), (">f4", np.float32), ("|i1", np.int16), ("<f8", np.float32),
                                           ("<u4", np.float32), (">i4", np.float32)])
def test_dtypes(tmp_path, dtype, stored):
    data = field((6, 7, 8), dtype, seed=2)
    path = tmp_path / "t.h5"
    write(path, "v", data, chunks=(3, 4, 4), compression="gzip")
    v = penumbra.read_volume(str(path))
    assert v.array.dtype == stored
    with h5py.File(path, "r") as f:
        np.testing.assert_array_equal(v.array, f["v"][()].astype(stored))


def test_unwritten_chunks_hold_the_fill_value(tmp_path):
    path = tmp_path / "sparse.h5"
    with h5py.File(path, "w") as f:
        d = f.create_dataset("v", shape=(8, 8, 8), dtype="<u2", chunks=(4, 4, 4), fillvalue=321, compression="gzip")
        d[:4, :4, :4] = field((4, 4, 4), "<u2")
    with h5py.File(path, "r") as f:
        expected = f["v"][()]
    assert (expected == 321).sum() == 512 - 64
    np.testing.assert_array_equal(penumbra.read_volume(str(path)).array, expected)


def test_dataset_path_channel_and_spacing(tmp_path):
    path = tmp_path / "many.h5"
    image = np.stack([field((6, 10, 12), "<u2", seed=c) for c in range(3)])
    with h5py.File(path, "w") as f:
        f.create_dataset("meta/labels", data=np.arange(10))
        f.create_dataset("raw/image", data=image, chunks=(1, 3, 5, 6), compression="gzip")
        f["raw/image"].attrs["element_size_um"] = [2.0, 0.5, 0.25]
        f.create_dataset("seg", data=field((6, 10, 12), "|u1"))
    with pytest.raises(penumbra.Error, match=r"2 datasets could be volumes; 'dataset' chooses one: /raw/image \(3x6x10x12 integer16\), /seg \(6x10x12 integer8\)"):
        penumbra.read_volume(str(path))
    v = penumbra.read_volume(str(path), dataset="/raw/image", channel=2)
    np.testing.assert_array_equal(v.array, image[2])
    assert v.spacing == pytest.approx((2.0, 0.5, 0.25)) and v.info["channels"] == 3 and v.info["channel"] == 2
    np.testing.assert_array_equal(penumbra.read_volume(str(path), dataset="raw/image").array, image[0])
    with pytest.raises(penumbra.Error, match="no dataset '/nope'"):
        penumbra.read_volume(str(path), dataset="/nope")
    with pytest.raises(penumbra.Error, match="'channel' 3: the dataset has 3 channels"):
        penumbra.read_volume(str(path), dataset="/raw/image", channel=3)
    with pytest.raises(penumbra.Error, match="a 1-D dataset"):
        penumbra.read_volume(str(path), dataset="/meta/labels")
    # a scene names the dataset
    scene = {"volumes": [{"file": str(path), "dataset": "/seg"}], "camera": {"width": 40, "height": 32}}
    assert penumbra.Renderer(penumbra.Scene(scene)).render().shape == (32, 40, 4)


def test_refusals(tmp_path):
    data = field((6, 8, 8), "<u2")
    lzf = tmp_path / "lzf.h5"
    write(lzf, "v", data, chunks=(3, 4, 4), compression="lzf")
    # h5py registers its lzf filter with the libhdf5 it shares with penumbra inside this process; the
    # command line has no h5py
    cli = subprocess.run([os.environ.get("PENUMBRA_CLI", "penumbra"), "info", str(lzf)], capture_output=True, text=True)
    assert cli.returncode != 0 and "filter 32000 = lzf (h5py's)" in cli.stderr and "cannot decode" in cli.stderr, cli.stderr
    none = tmp_path / "flat.h5"
    write(none, "table", np.arange(12.0).reshape(3, 4))
    with pytest.raises(penumbra.Error, match=r"no numeric dataset of three or more axes \(found: /table \(3x4 float64\)\)"):
        penumbra.read_volume(str(none))
    good = tmp_path / "good.h5"
    write(good, "v", field((32, 32, 32), "<f4"), chunks=(8, 8, 8), compression="gzip")
    cut = tmp_path / "cut.h5"
    cut.write_bytes(good.read_bytes()[: os.path.getsize(good) * 2 // 3])
    with pytest.raises(penumbra.Error):
        penumbra.read_volume(str(cut))
    fake = tmp_path / "fake.h5"
    fake.write_bytes(b"not hdf5 at all" * 10)
    with pytest.raises(penumbra.Error, match="not an HDF5 file"):
        penumbra.read_volume(str(fake))
    with pytest.raises(penumbra.Error, match="'dataset' is for HDF5 files"):
        penumbra.read_volume(str(tmp_path / "x.nrrd"), dataset="/v")


def test_the_cli_opens_a_dataset(tmp_path):
    cli = os.environ.get("PENUMBRA_CLI", "penumbra")
    path = tmp_path / "two.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("a", data=field((8, 9, 10), "<u2"))
        f.create_dataset("b", data=field((8, 9, 10), "<f4"))
    info = subprocess.run([cli, "info", str(path), "--dataset", "/b"], capture_output=True, text=True)
    assert info.returncode == 0 and "format      hdf5" in info.stdout and "10 x 9 x 8" in info.stdout, info.stdout + info.stderr
    out = tmp_path / "b.png"
    r = subprocess.run([cli, "render", str(path), "--dataset", "/a", "--width", "40", "--height", "32", "-o", str(out)], capture_output=True, text=True)
    assert r.returncode == 0 and out.exists(), r.stderr
    bad = subprocess.run([cli, "render", str(path), "-o", str(tmp_path / "c.png")], capture_output=True, text=True)
    assert bad.returncode != 0 and "'dataset' chooses one" in bad.stderr and not (tmp_path / "c.png").exists()


def test_damaged_files_give_an_error_or_voxels_never_a_crash(tmp_path):
    """64 bytes overwritten with 0x79 at every 64th offset of a chunked gzip file: libhdf5 runs in a child
    process with a memory budget (hdf5_loader.cpp), so each read either gives voxels or a penumbra.Error,
    and this process lives on."""
    good = tmp_path / "good.h5"
    write(good, "v", field((16, 16, 16), "<u2"), chunks=(8, 8, 8), compression="gzip")
    original = good.read_bytes()
    bad = tmp_path / "bad.h5"
    errors = 0
    for offset in range(0, len(original), 64):
        damaged = bytearray(original)
        damaged[offset:offset + 64] = b"\x79" * len(damaged[offset:offset + 64])
        bad.write_bytes(bytes(damaged))
        try:
            v = penumbra.read_volume(str(bad))
            assert v.array.shape == (16, 16, 16)
        except penumbra.Error as e:
            errors += 1
            assert str(bad) in str(e) and len(str(e)) > len(str(bad)) + 10
    assert errors > 0
