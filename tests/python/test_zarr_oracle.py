"""Zarr v2 stores and OME-Zarr 0.4 pyramids (issue 43, its first part: the reader), written by
python3-zarr and read back by penumbra: every voxel as zarr reads it, for each codec (blosc with lz4,
zstd, zlib; zlib; gzip; zstd; none), dtype, chunk layout (edge chunks, "/" separators, Fortran order)
and the pyramid's levels, channels and transformations; missing chunks hold the fill value; a corrupt
chunk, an unknown codec, a filter and a Zarr v3 group without an image are refused by name."""
import json
import os

import numpy as np
import pytest

zarr = pytest.importorskip("zarr")  # Debian python3-zarr (scripts/install-deps.sh)
from numcodecs import GZip, Zlib, Zstd, Blosc  # noqa: E402

import penumbra  # noqa: E402
from volume_fields import field  # noqa: E402


def read(path, **kwargs):
    v = penumbra.read_volume(str(path), **kwargs)
    return v


CODECS = {
    "none": None,
    "blosc-lz4": Blosc(cname="lz4", clevel=5, shuffle=Blosc.SHUFFLE),
    "blosc-zstd": Blosc(cname="zstd", clevel=3, shuffle=Blosc.BITSHUFFLE),
    "blosc-zlib": Blosc(cname="zlib", clevel=4, shuffle=Blosc.NOSHUFFLE),
    "zlib": Zlib(level=6),
    "gzip": GZip(level=5),
    "zstd": Zstd(level=3),
}


@pytest.mark.parametrize("codec", list(CODECS))
def test_every_codec_reads_as_zarr_reads(tmp_path, codec):
    data = field((19, 23, 30), "<u2")
    path = tmp_path / f"{codec}.zarr"
    z = zarr.open(str(path), mode="w", shape=data.shape, chunks=(8, 10, 16), dtype=data.dtype, compressor=CODECS[codec])
    z[:] = data
    v = read(path)
    np.testing.assert_array_equal(v.array, zarr.open(str(path), mode="r")[:])
    assert v.array.dtype == np.uint16 and v.info["format"] == "zarr"


@pytest.mark.parametrize("dtype, stored", [("|u1", np.uint8), ("<i2", np.int16), ("<u2", np.uint16), (">u2", np.uint16),
                                           ("<f4", np.float32), (">f4", np.float32), ("|i1", np.int16), ("<f8", np.float32),
                                           ("<u4", np.float32), ("<i4", np.float32)])
def test_dtypes(tmp_path, dtype, stored):
    data = field((9, 11, 13), dtype, seed=3)
    path = tmp_path / "a.zarr"
    z = zarr.open(str(path), mode="w", shape=data.shape, chunks=(4, 4, 4), dtype=dtype, compressor=CODECS["blosc-lz4"])
    z[:] = data
    v = read(path)
    assert v.array.dtype == stored
    np.testing.assert_array_equal(v.array, zarr.open(str(path), mode="r")[:].astype(stored))


def test_slash_separator_and_fortran_order(tmp_path):
    data = field((10, 12, 14), "<i2", seed=4)
    for order, sep in (("F", "."), ("C", "/"), ("F", "/")):
        path = tmp_path / f"{order}{'slash' if sep == '/' else 'dot'}.zarr"
        store = zarr.DirectoryStore(str(path), dimension_separator=sep)
        z = zarr.create(store=store, shape=data.shape, chunks=(3, 5, 6), dtype=data.dtype, order=order, compressor=CODECS["zstd"])
        z[:] = data
        np.testing.assert_array_equal(read(path).array, data)


def test_missing_chunks_hold_the_fill_value(tmp_path):
    data = field((8, 8, 8), "<u2", seed=5)
    path = tmp_path / "holes.zarr"
    z = zarr.open(str(path), mode="w", shape=data.shape, chunks=(4, 4, 4), dtype=data.dtype, fill_value=777, compressor=CODECS["zlib"])
    z[:] = data
    os.remove(path / "1.0.1")
    os.remove(path / "0.1.0")
    expected = zarr.open(str(path), mode="r")[:]
    assert (expected == 777).sum() == 2 * 64
    v = read(path)
    np.testing.assert_array_equal(v.array, expected)
    assert any("2 of 8 chunks are not stored" in n for n in v.info["notes"])


def ome_zarr(path, levels, channels=1, scale=(0.5, 0.25, 0.2), translation=(10.0, -3.0, 2.0), unit="micrometer", dtype="<u2"):
    """An OME-Zarr 0.4 image written with zarr: axes c z y x, level l downsampled by 2^l in y and x."""
    root = zarr.open_group(str(path), mode="w")
    full = np.stack([field((12, 40, 36), dtype, seed=10 + c) for c in range(channels)])
    datasets = []
    for level in range(levels):
        f = 2 ** level
        arr = full[:, :, ::f, ::f]
        root.create_dataset(str(level), data=arr, chunks=(1, 5, 16, 16), compressor=CODECS["blosc-zstd"])
        datasets.append({"path": str(level), "coordinateTransformations": [
            {"type": "scale", "scale": [1.0, scale[0], scale[1] * f, scale[2] * f]},
            {"type": "translation", "translation": [0.0, translation[0], translation[1], translation[2]]}]})
    root.attrs["multiscales"] = [{
        "version": "0.4", "name": "test",
        "axes": [{"name": "c", "type": "channel"}] + [{"name": n, "type": "space", "unit": unit} for n in "zyx"],
        "datasets": datasets}]
    return full


def test_ome_zarr_levels_channels_and_placement(tmp_path):
    path = tmp_path / "image.zarr"
    full = ome_zarr(path, levels=3, channels=2)
    v = read(path, level=0, channel=1)
    np.testing.assert_array_equal(v.array, full[1])
    assert v.spacing == pytest.approx((0.5, 0.25, 0.2)) and v.origin == pytest.approx((10.0, -3.0, 2.0))  # z, y, x
    assert v.info["channels"] == 2 and v.info["channel"] == 1
    v2 = read(path, level=2)
    np.testing.assert_array_equal(v2.array, zarr.open(str(path / "2"), mode="r")[0])
    assert v2.spacing == pytest.approx((0.5, 1.0, 0.8))
    assert any("level 2 of 3" in n for n in v2.info["notes"]) and any("micrometer" in n for n in v2.info["notes"])
    # by default the finest level that fits: here the finest
    np.testing.assert_array_equal(read(path).array, full[0])


def test_an_ome_zarr_image_renders_in_a_scene(tmp_path):
    path = tmp_path / "image.zarr"
    ome_zarr(path, levels=2)
    scene = {"volumes": [{"file": str(path), "level": 1}], "camera": {"width": 48, "height": 40}}
    r = penumbra.Renderer(penumbra.Scene(scene))
    image = r.render()
    assert image.shape == (40, 48, 4) and np.asarray(image)[..., :3].std() > 1
    with pytest.raises(penumbra.Error, match="'level' 5: the pyramid has 2 levels"):
        penumbra.Renderer(penumbra.Scene({"volumes": [{"file": str(path), "level": 5}]}))


@pytest.mark.parametrize("damage, expected", [
    ("truncate", "chunk"),
    ("garbage", "chunk"),
])
def test_a_corrupt_chunk_is_refused_naming_it(tmp_path, damage, expected):
    data = field((8, 8, 8), "<u2")
    # zeros in place of an uncompressed chunk are valid voxels: "none" is only truncated
    for codec in ("blosc-lz4", "zlib", "gzip", "zstd") + (("none",) if damage == "truncate" else ()):
        path = tmp_path / f"{codec}-{damage}.zarr"
        z = zarr.open(str(path), mode="w", shape=data.shape, chunks=(4, 4, 4), dtype=data.dtype, compressor=CODECS[codec])
        z[:] = data
        chunk = path / "1.1.0"
        raw = chunk.read_bytes()
        chunk.write_bytes(raw[: len(raw) // 2] if damage == "truncate" else bytes(len(raw)))
        with pytest.raises(penumbra.Error) as e:
            read(path)
        assert str(chunk) in str(e.value), (codec, str(e.value))


def test_refusals(tmp_path):
    data = field((4, 4, 4), "<u2")
    path = tmp_path / "lz4.zarr"
    z = zarr.open(str(path), mode="w", shape=data.shape, chunks=(4, 4, 4), dtype=data.dtype, compressor=CODECS["zlib"])
    z[:] = data
    meta = json.loads((path / ".zarray").read_text())
    for change, message in ((lambda m: m.update(compressor={"id": "lz4", "acceleration": 1}), 'compressor "lz4" is not supported'),
                            (lambda m: m.update(filters=[{"id": "delta", "dtype": "<u2"}]), "filters"),
                            (lambda m: m.update(dtype="<c8"), 'dtype "<c8" is not supported'),
                            (lambda m: m.update(shape=[4, 4], chunks=[4, 4]), "a 2-D array"),
                            (lambda m: m.update(shape=[4, 4]), '"shape" and "chunks" have different lengths'),
                            (lambda m: m.update(chunks=[4, 4, 8]), "chunk"),
                            (lambda m: m.update(order=3), r'"order" is 3 \(expected a string\)')):
        m = dict(meta)
        change(m)
        (path / ".zarray").write_text(json.dumps(m))
        with pytest.raises(penumbra.Error, match=message):
            read(path)
    (path / ".zarray").write_text(json.dumps(meta))
    np.testing.assert_array_equal(read(path).array, data)
    v3 = tmp_path / "v3.zarr"
    v3.mkdir()
    (v3 / "zarr.json").write_text('{"zarr_format": 3, "node_type": "group"}')
    with pytest.raises(penumbra.Error, match="a Zarr group without \"multiscales\" in its zarr.json attributes"):
        read(v3)  # a v3 group that is no OME-Zarr 0.5 image (v3 stores: test_zarr_v3.py)
    with pytest.raises(penumbra.Error, match="'level' is for OME-Zarr pyramids"):
        penumbra.read_volume(str(path) + "/../lz4.zarr/.zarray", level=1)


def test_the_cli_opens_a_pyramid_at_a_level(tmp_path):
    import subprocess
    cli = os.environ.get("PENUMBRA_CLI", "penumbra")
    path = tmp_path / "image.zarr"
    ome_zarr(path, levels=3, channels=2)
    info = subprocess.run([cli, "info", str(path), "--level", "2", "--channel", "1"], capture_output=True, text=True)
    assert info.returncode == 0, info.stderr
    assert "pyramid levels (x y z voxels) 0: 36x40x12, 1: 18x20x12, 2: 9x10x12" in info.stdout
    assert "OME-Zarr level 2 of 3" in info.stdout and "channels    2 (channel 1 loaded)" in info.stdout
    out = tmp_path / "a.png"
    render = subprocess.run([cli, "render", str(path), "--level", "1", "--width", "48", "--height", "40", "-o", str(out)],
                            capture_output=True, text=True)
    assert render.returncode == 0 and out.exists(), render.stderr
    bad = subprocess.run([cli, "render", str(path), "--level", "7", "-o", str(tmp_path / "b.png")], capture_output=True, text=True)
    assert bad.returncode != 0 and "'level' 7: the pyramid has 3 levels" in bad.stderr and not (tmp_path / "b.png").exists()
