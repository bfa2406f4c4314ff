"""Zarr v3 stores and OME-Zarr 0.5 images (issue 43: "0.5 on Zarr v3"), read back by penumbra voxel for
voxel. Debian's python3-zarr (2.13) writes no v3, so this file writes stores as the v3 core spec lays
them out — zarr.json, "c/…" chunk keys, the codec chain (transpose, bytes, blosc/gzip/zstd through
numcodecs, crc32c) and sharding_indexed shards with their index at the end or the start — from NumPy
arrays, which are the oracle; each codec, dtype, byte order, F order, missing chunks and inner chunks
(fill value), an OME-Zarr 0.5 pyramid's levels, channel and placement, a render, a streamed convert,
and the refusals: an unknown codec, a corrupt CRC32C, a shard index pointing past its file, a chunk
of the wrong size."""
import itertools
import json
import os
import struct
import subprocess

import numpy as np
import pytest

numcodecs = pytest.importorskip("numcodecs")  # Debian python3-numcodecs (with python3-zarr)
zarr = pytest.importorskip("zarr")

import penumbra  # noqa: E402
from volume_fields import field  # noqa: E402

CLI = os.environ.get("PENUMBRA_CLI", "penumbra")
NO_CHUNK = 2**64 - 1

_CRC_TABLE = []
for _i in range(256):
    _c = _i
    for _ in range(8):
        _c = 0x82F63B78 ^ (_c >> 1) if _c & 1 else _c >> 1
    _CRC_TABLE.append(_c)


def crc32c(data):
    crc = 0xFFFFFFFF
    for b in data:
        crc = _CRC_TABLE[(crc ^ b) & 0xFF] ^ (crc >> 8)
    return crc ^ 0xFFFFFFFF


def test_crc32c_is_castagnolis():
    assert crc32c(b"123456789") == 0xE3069283  # the check value of CRC-32C (RFC 3720)


V3_TYPES = {"uint8": "u1", "int8": "i1", "uint16": "u2", "int16": "i2", "uint32": "u4", "int32": "i4", "float32": "f4", "float64": "f8"}

BYTES_CODECS = {
    "blosc-lz4": ({"name": "blosc", "configuration": {"cname": "lz4", "clevel": 5, "shuffle": "shuffle", "typesize": 2, "blocksize": 0}},
                  numcodecs.Blosc(cname="lz4", clevel=5, shuffle=numcodecs.Blosc.SHUFFLE)),
    "blosc-zstd": ({"name": "blosc", "configuration": {"cname": "zstd", "clevel": 3, "shuffle": "bitshuffle", "typesize": 2, "blocksize": 0}},
                   numcodecs.Blosc(cname="zstd", clevel=3, shuffle=numcodecs.Blosc.BITSHUFFLE)),
    "gzip": ({"name": "gzip", "configuration": {"level": 5}}, numcodecs.GZip(level=5)),
    "zstd": ({"name": "zstd", "configuration": {"level": 3, "checksum": False}}, numcodecs.Zstd(level=3)),
}


def chain(codecs, endian, order):
    """The codec list's JSON and an encoder of one chunk (a full-size array) to its stored bytes."""
    ndim_order = order
    meta = ([{"name": "transpose", "configuration": {"order": ndim_order}}] if ndim_order else []) + \
           [{"name": "bytes", "configuration": {"endian": endian}}]
    for c in codecs:
        meta.append({"name": "crc32c"} if c == "crc32c" else BYTES_CODECS[c][0])

    def encode(chunk):
        a = np.transpose(chunk, ndim_order) if ndim_order else chunk
        data = np.ascontiguousarray(a).astype(a.dtype.newbyteorder("<" if endian == "little" else ">")).tobytes()
        for c in codecs:
            data = data + struct.pack("<I", crc32c(data)) if c == "crc32c" else bytes(BYTES_CODECS[c][1].encode(data))
        return data
    return meta, encode


def chunk_of(data, index, shape, fill):
    """The chunk at `index` (full size: the array's edge padded with the fill value)."""
    out = np.full(shape, fill, dtype=data.dtype)
    src = tuple(slice(i * s, min((i + 1) * s, n)) for i, s, n in zip(index, shape, data.shape))
    part = data[src]
    out[tuple(slice(0, p) for p in part.shape)] = part
    return out


def grid(shape, chunks):
    return itertools.product(*(range(-(-n // c)) for n, c in zip(shape, chunks)))


def write_v3(folder, data, chunks, codecs=("gzip",), endian="little", order=None, fill=0, separator="/", encoding="default",
             shard=None, index_at="end", index_crc=True, skip=(), skip_inner=(), attributes=None):
    """A Zarr v3 array of `data` in `folder`. `shard`: shards of that shape holding chunks of `chunks`;
    `skip`: chunk (or shard) indices not written; `skip_inner`: inner chunks (array chunk indices) left
    out of their shard's index."""
    folder.mkdir(parents=True, exist_ok=True)
    inner_meta, encode = chain(codecs, endian, order)
    if shard:
        index_codecs = [{"name": "bytes", "configuration": {"endian": "little"}}] + ([{"name": "crc32c"}] if index_crc else [])
        codec_meta = [{"name": "sharding_indexed", "configuration": {"chunk_shape": list(chunks), "codecs": inner_meta,
                                                                    "index_codecs": index_codecs, "index_location": index_at}}]
        outer = shard
    else:
        codec_meta, outer = inner_meta, chunks
    type_name = next(k for k, v in V3_TYPES.items() if np.dtype(v) == data.dtype.newbyteorder("="))
    meta = {"zarr_format": 3, "node_type": "array", "shape": list(data.shape), "data_type": type_name,
            "chunk_grid": {"name": "regular", "configuration": {"chunk_shape": list(outer)}},
            "chunk_key_encoding": {"name": encoding, "configuration": {"separator": separator}},
            "fill_value": fill, "codecs": codec_meta, "attributes": attributes or {}}
    (folder / "zarr.json").write_text(json.dumps(meta))
    prefix = ["c"] if encoding == "default" else []
    for index in grid(data.shape, outer):
        if index in skip:
            continue
        if shard:
            per = [s // c for s, c in zip(shard, chunks)]
            table, blobs = [], []
            n_index = 16 * int(np.prod(per)) + (4 if index_crc else 0)
            offset = n_index if index_at == "start" else 0
            for inner in itertools.product(*(range(p) for p in per)):
                global_index = tuple(i * p + j for i, p, j in zip(index, per, inner))
                inside = all(g * c < n for g, c, n in zip(global_index, chunks, data.shape))
                if not inside or global_index in skip_inner:
                    table.append((NO_CHUNK, NO_CHUNK))
                    continue
                blob = encode(chunk_of(data, global_index, chunks, fill))
                table.append((offset, len(blob)))
                blobs.append(blob)
                offset += len(blob)
            index_bytes = b"".join(struct.pack("<QQ", o, n) for o, n in table)
            if index_crc:
                index_bytes += struct.pack("<I", crc32c(index_bytes))
            body = b"".join(blobs)
            content = index_bytes + body if index_at == "start" else body + index_bytes
        else:
            content = encode(chunk_of(data, index, chunks, fill))
        path = folder.joinpath(*prefix, *map(str, index)) if separator == "/" else folder / separator.join(prefix + list(map(str, index)))
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(content)
    return folder


def read(path, **kwargs):
    return penumbra.read_volume(str(path), **kwargs)


@pytest.mark.parametrize("codecs", [(), ("blosc-lz4",), ("blosc-zstd",), ("gzip",), ("zstd",), ("zstd", "crc32c"), ("crc32c",)])
def test_every_codec_reads_voxel_for_voxel(tmp_path, codecs):
    data = field((11, 17, 19), "<u2")
    v = read(write_v3(tmp_path / "a.zarr", data, (4, 8, 8), codecs=codecs))
    np.testing.assert_array_equal(v.array, data)
    assert v.info["format"] == "zarr" and v.array.dtype == np.uint16


@pytest.mark.parametrize("dtype, stored", [("|u1", np.uint8), ("<i2", np.int16), ("<u2", np.uint16), ("<f4", np.float32), ("|i1", np.int16),
                                           ("<f8", np.float32), ("<u4", np.float32), ("<i4", np.float32)])
@pytest.mark.parametrize("endian", ["little", "big"])
def test_dtypes_and_byte_orders(tmp_path, dtype, stored, endian):
    data = field((6, 7, 9), dtype, seed=2)
    v = read(write_v3(tmp_path / "t.zarr", data, (3, 4, 4), endian=endian))
    assert v.array.dtype == stored
    np.testing.assert_array_equal(v.array, data.astype(stored))


def test_f_order_dot_keys_and_v2_key_encoding(tmp_path):
    data = field((9, 10, 11), "<u2", seed=3)
    np.testing.assert_array_equal(read(write_v3(tmp_path / "f.zarr", data, (4, 4, 4), order=[2, 1, 0])).array, data)
    np.testing.assert_array_equal(read(write_v3(tmp_path / "dot.zarr", data, (4, 4, 4), separator=".")).array, data)
    np.testing.assert_array_equal(read(write_v3(tmp_path / "v2.zarr", data, (4, 4, 4), encoding="v2", separator=".")).array, data)
    assert (tmp_path / "v2.zarr" / "0.0.0").is_file() and (tmp_path / "f.zarr" / "c" / "0" / "0" / "0").is_file()


def test_missing_chunks_hold_the_fill_value(tmp_path):
    data = field((8, 8, 8), "<u2", seed=4)
    v = read(write_v3(tmp_path / "m.zarr", data, (4, 4, 8), fill=77, skip={(0, 0, 0), (1, 1, 0)}))
    expected = data.copy()
    expected[0:4, 0:4, :] = 77
    expected[4:8, 4:8, :] = 77
    np.testing.assert_array_equal(v.array, expected)
    assert any("2 of 4 chunks are not stored" in n for n in v.info["notes"])


@pytest.mark.parametrize("index_at, index_crc", [("end", True), ("start", True), ("end", False)])
def test_shards_read_their_inner_chunks(tmp_path, index_at, index_crc):
    """Shards of 2×2×2 inner chunks (edge shards part empty), the index at either end, with and without
    its CRC32C; an inner chunk left out of its index and a shard not written hold the fill value."""
    data = field((13, 18, 20), "<u2", seed=5)
    v = read(write_v3(tmp_path / "s.zarr", data, (4, 5, 6), codecs=("blosc-lz4",), shard=(8, 10, 12), index_at=index_at,
                      index_crc=index_crc, fill=5, skip={(1, 1, 1)}, skip_inner={(0, 0, 1)}))
    expected = data.copy()
    expected[8:16, 10:20, 12:24] = 5  # shard (1, 1, 1)
    expected[0:4, 0:5, 6:12] = 5      # inner chunk (0, 0, 1)
    np.testing.assert_array_equal(v.array, expected)


def ome_zarr_05(path, levels=2, channels=2, scale=(0.5, 0.25, 0.2), translation=(10.0, -3.0, 2.0), shard=None):
    """An OME-Zarr 0.5 image: a v3 group whose attributes.ome holds multiscales; axes c z y x, level l
    downsampled by 2^l in y and x."""
    full = np.stack([field((12, 40, 36), "<u2", seed=20 + c) for c in range(channels)])
    datasets = []
    for level in range(levels):
        f = 2 ** level
        write_v3(path / str(level), np.ascontiguousarray(full[:, :, ::f, ::f]), (1, 5, 16, 16), codecs=("zstd", "crc32c"), shard=shard)
        datasets.append({"path": str(level), "coordinateTransformations": [
            {"type": "scale", "scale": [1.0, scale[0], scale[1] * f, scale[2] * f]},
            {"type": "translation", "translation": [0.0, *translation]}]})
    ome = {"version": "0.5", "multiscales": [{"name": "test", "datasets": datasets,
                                             "axes": [{"name": "c", "type": "channel"}] +
                                                     [{"name": n, "type": "space", "unit": "micrometer"} for n in "zyx"]}]}
    (path / "zarr.json").write_text(json.dumps({"zarr_format": 3, "node_type": "group", "attributes": {"ome": ome}}))
    return full


@pytest.mark.parametrize("shard", [None, (1, 10, 32, 32)])
def test_an_ome_zarr_05_image_its_levels_channel_and_placement(tmp_path, shard):
    path = tmp_path / "image.ome.zarr"
    full = ome_zarr_05(path, levels=3, shard=shard)
    v = read(path, level=0, channel=1)
    np.testing.assert_array_equal(v.array, full[1])
    assert v.spacing == pytest.approx((0.5, 0.25, 0.2)) and v.origin == pytest.approx((10.0, -3.0, 2.0))  # z, y, x
    assert v.info["channels"] == 2 and v.info["channel"] == 1
    v2 = read(path, level=2)
    np.testing.assert_array_equal(v2.array, full[0, :, ::4, ::4])
    assert v2.spacing == pytest.approx((0.5, 1.0, 0.8)) and any("level 2 of 3" in n for n in v2.info["notes"])


def test_an_ome_zarr_05_image_renders_and_converts_streamed(tmp_path):
    path = tmp_path / "image.ome.zarr"
    full = ome_zarr_05(path, levels=2, channels=1, shard=(1, 10, 32, 32))
    image = penumbra.Renderer(penumbra.Scene({"volumes": [{"file": str(path)}], "camera": {"width": 48, "height": 40}})).render()
    assert image.shape == (40, 48, 4) and np.asarray(image)[..., :3].std() > 1
    out = tmp_path / "v2.zarr"
    r = subprocess.run([CLI, "convert", str(path), "-o", str(out), "--chunk", "8"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "from zarr (streamed)" in r.stdout
    np.testing.assert_array_equal(zarr.open_group(str(out), mode="r")["0"][:], full[0])


def test_refusals_name_what_is_wrong(tmp_path):
    data = field((4, 4, 4), "<u2")
    path = write_v3(tmp_path / "a.zarr", data, (4, 4, 4), codecs=("gzip", "crc32c"))
    meta = json.loads((path / "zarr.json").read_text())
    for change, message in (
            (lambda m: m["codecs"].append({"name": "bitround", "configuration": {"keepbits": 3}}), 'the codec "bitround" after the bytes codec is not supported'),
            (lambda m: m["codecs"].insert(0, {"name": "transpose", "configuration": {"order": [1, 0, 2]}}), r"a transpose of order \[1,0,2\]"),
            (lambda m: m.update(data_type="complex64"), "data_type complex64 is not supported"),
            (lambda m: m.update(chunk_grid={"name": "rectilinear"}), "chunk_grid"),
            (lambda m: m.update(chunk_key_encoding={"name": "nested"}), "chunk_key_encoding"),
            (lambda m: m.update(codecs=[]), '"codecs" missing'),
            (lambda m: m["chunk_grid"]["configuration"].update(chunk_shape=[4, 4, 8]), "gzip data is corrupt or holds 128 bytes"),  # a lying chunk shape
            (lambda m: m.update(node_type="group"), 'a Zarr group without "multiscales"'),
            (lambda m: m.update(node_type=5), r'"node_type" is 5 \(expected a string\)'),  # fuzz_zarr found such a field thrown past the reader
            (lambda m: m["codecs"][0]["configuration"].update(endian=["little"]), r'"endian" is \["little"\] \(expected a string\)')):
        m = json.loads(json.dumps(meta))
        change(m)
        (path / "zarr.json").write_text(json.dumps(m))
        with pytest.raises(penumbra.Error, match=message):
            read(path)
    (path / "zarr.json").write_text(json.dumps(meta))
    np.testing.assert_array_equal(read(path).array, data)
    chunk = path / "c" / "0" / "0" / "0"
    stored = bytearray(chunk.read_bytes())
    stored[-1] ^= 0xFF
    chunk.write_bytes(bytes(stored))
    with pytest.raises(penumbra.Error, match=r"c/0/0/0: the chunk: its CRC32C does not match"):
        read(path)
    # a shard whose index points past the end of its file
    sharded = write_v3(tmp_path / "s.zarr", data, (2, 2, 4), codecs=(), shard=(4, 4, 4), index_crc=False)
    shard_file = sharded / "c" / "0" / "0" / "0"
    content = bytearray(shard_file.read_bytes())
    struct.pack_into("<QQ", content, len(content) - 64, 10**6, 64)
    shard_file.write_bytes(bytes(content))
    with pytest.raises(penumbra.Error, match="its index puts chunk 0 at bytes 1000000"):
        read(sharded)
