#!/usr/bin/env python3
"""Load time and peak memory of each volume format (issue 19) against the same voxels from NRRD:
`penumbra info FILE --bins 1` in a fresh process per run; the time is the reader's own ("read in X ms"),
the memory the process's peak resident set (GNU time, Debian package `time`). The NRRD twins (raw and gzip encodings) are
written from the voxels penumbra read, so both sides hold exactly the same data.

    scripts/bench_loaders.py [--build build/release] [--runs 5] [--out DIR]

Files: ../shared/data (PROVENANCE.md "Loader formats"). Prints a Markdown table, writes loaders.json.

Chunked stores (issue 43): the DICOM CT's voxels written as Zarr v2 (python3-zarr: Blosc lz4 and zstd,
gzip, 64³ chunks) and as HDF5 (h5py: contiguous, and 64³ chunks with gzip and shuffle), read by penumbra
(`penumbra info`, its own read time and peak RSS) and by zarr / h5py themselves (in this process,
median of --runs). Prints a second table, writes chunked.json.
"""
import argparse
import gzip
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "..", "shared", "data")

CASES = [  # (label, path relative to DATA, extra CLI arguments)
    ("DICOM series (50 slices, uncompressed)", "dicom_pancreas_ct", []),
    ("TIFF 8-bit, 106 pages", "arabidopsis_embryo.tif", []),
    ("TIFF 16-bit hyperstack, channel 1 of 2", "nucleus_conf_wf.tif", ["--channel", "1"]),
    ("VTI appended raw", "headsq_appended_raw.vti", []),
    ("VTI appended zlib", "headsq_appended_zlib.vti", []),
    ("VTI base64 + zlib (VTK default)", "headsq_vtkdefault.vti", []),
    ("legacy VTK binary", "headsq.vtk", []),
]

NRRD_TYPES = {np.dtype("uint8"): "uchar", np.dtype("int16"): "short", np.dtype("uint16"): "ushort", np.dtype("float32"): "float"}


def measure(cli, args, runs):
    """Median read time (ms) and peak RSS (MiB) of `penumbra info ARGS` over `runs` processes. GNU time
    starts each process, so that its peak is its own (a child forked from this Python process would
    count the parent's memory before exec)."""
    times, peaks = [], []
    for _ in range(runs):
        r = subprocess.run(["/usr/bin/time", "-f", "peak_kib=%M", cli, "info", *args, "--bins", "1"], capture_output=True, text=True)
        if r.returncode != 0:
            sys.exit(f"penumbra info {' '.join(args)} failed: {r.stderr}")
        times.append(float(re.search(r"read in ([0-9.]+) ms", r.stdout).group(1)))
        peaks.append(int(re.search(r"peak_kib=([0-9]+)", r.stderr).group(1)) / 1024.0)
    return statistics.median(times), statistics.median(peaks)


def write_nrrd(path, array, spacing, origin, gzipped):
    header = (f"NRRD0004\ntype: {NRRD_TYPES[array.dtype]}\ndimension: 3\nsizes: {array.shape[2]} {array.shape[1]} {array.shape[0]}\n"
              f"spacings: {spacing[0]!r} {spacing[1]!r} {spacing[2]!r}\n"
              f"encoding: {'gzip' if gzipped else 'raw'}\nendian: little\n\n")
    body = np.ascontiguousarray(array).astype(array.dtype.newbyteorder("<")).tobytes()
    with open(path, "wb") as f:
        f.write(header.encode())
        f.write(gzip.compress(body, 6) if gzipped else body)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build", "release"))
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--out", default=".")
    a = ap.parse_args()
    sys.path.insert(0, os.path.join(a.build, "python"))
    import penumbra  # the build's package: its reader makes the NRRD twins
    cli = os.path.join(a.build, "penumbra")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for label, name, extra in CASES:
            path = os.path.join(DATA, name)
            if not os.path.exists(path):
                print(f"skipped (not found): {path}", file=sys.stderr)
                continue
            channel = int(extra[1]) if extra else None
            v = penumbra.read_volume(path, channel=channel)
            size = sum(os.path.getsize(os.path.join(path, f)) for f in os.listdir(path)) if os.path.isdir(path) else os.path.getsize(path)
            row = {"format": label, "file": name, "voxels": int(v.array.size), "type": str(v.array.dtype), "bytes_on_disk": size}
            row["read_ms"], row["peak_mib"] = measure(cli, [path, *extra], a.runs)
            for enc in ("raw", "gzip"):
                twin = os.path.join(tmp, f"twin_{enc}.nrrd")
                write_nrrd(twin, v.array, v.spacing, v.origin, enc == "gzip")
                row[f"nrrd_{enc}_ms"], row[f"nrrd_{enc}_peak_mib"] = measure(cli, [twin], a.runs)
            rows.append(row)
        chunked = chunked_rows(cli, penumbra, tmp, a.runs)
    print("| format | voxels, type | on disk | read | peak RSS | same voxels as raw NRRD | as gzip NRRD |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['format']} | {r['voxels']:,} {r['type']} | {r['bytes_on_disk'] / 2**20:.1f} MiB | {r['read_ms']:.1f} ms | "
              f"{r['peak_mib']:.0f} MiB | {r['nrrd_raw_ms']:.1f} ms, {r['nrrd_raw_peak_mib']:.0f} MiB | "
              f"{r['nrrd_gzip_ms']:.1f} ms, {r['nrrd_gzip_peak_mib']:.0f} MiB |")
    print()
    print("| store | on disk | penumbra read | peak RSS | the writer's library reads it in |")
    print("|---|---|---|---|---|")
    for r in chunked:
        print(f"| {r['store']} | {r['bytes_on_disk'] / 2**20:.1f} MiB | {r['read_ms']:.1f} ms | {r['peak_mib']:.0f} MiB | "
              f"{r['library']} {r['library_ms']:.1f} ms |")
    os.makedirs(a.out, exist_ok=True)
    with open(os.path.join(a.out, "loaders.json"), "w") as f:
        json.dump(rows, f, indent=2)
    with open(os.path.join(a.out, "chunked.json"), "w") as f:
        json.dump(chunked, f, indent=2)


def disk_bytes(path):
    if os.path.isfile(path):
        return os.path.getsize(path)
    return sum(os.path.getsize(os.path.join(d, f)) for d, _, files in os.walk(path) for f in files)


def chunked_rows(cli, penumbra, tmp, runs):
    """Zarr and HDF5 copies of the DICOM CT, read by penumbra and by zarr / h5py."""
    import time
    try:
        import h5py
        import zarr
        from numcodecs import Blosc, GZip
    except ImportError as e:
        print(f"chunked stores skipped: {e}", file=sys.stderr)
        return []
    ct = os.path.join(DATA, "dicom_pancreas_ct")
    if not os.path.exists(ct):
        return []
    voxels = penumbra.read_volume(ct).array
    stores = [("Zarr, Blosc lz4 + shuffle, 64³ chunks", "lz4.zarr", Blosc(cname="lz4", clevel=5, shuffle=Blosc.SHUFFLE)),
              ("Zarr, Blosc zstd + bitshuffle, 64³ chunks", "zstd.zarr", Blosc(cname="zstd", clevel=3, shuffle=Blosc.BITSHUFFLE)),
              ("Zarr, gzip, 64³ chunks", "gzip.zarr", GZip(level=5))]
    rows = []
    for label, name, codec in stores:
        path = os.path.join(tmp, name)
        z = zarr.open(path, mode="w", shape=voxels.shape, chunks=(64, 64, 64), dtype=voxels.dtype, compressor=codec)
        z[:] = voxels
        times = []
        for _ in range(runs):
            t = time.perf_counter()
            zarr.open(path, mode="r")[:]
            times.append((time.perf_counter() - t) * 1000)
        row = {"store": label, "bytes_on_disk": disk_bytes(path), "library": "zarr", "library_ms": statistics.median(times)}
        row["read_ms"], row["peak_mib"] = measure(cli, [path], runs)
        rows.append(row)
    for label, name, options in (("HDF5, contiguous", "flat.h5", {}),
                                 ("HDF5, 64³ chunks, gzip + shuffle", "gzip.h5", {"chunks": (min(64, voxels.shape[0]), 64, 64), "compression": "gzip", "shuffle": True})):
        path = os.path.join(tmp, name)
        with h5py.File(path, "w") as f:
            f.create_dataset("ct", data=voxels, **options)
        times = []
        for _ in range(runs):
            t = time.perf_counter()
            with h5py.File(path, "r") as f:
                f["ct"][()]
            times.append((time.perf_counter() - t) * 1000)
        row = {"store": label, "bytes_on_disk": disk_bytes(path), "library": "h5py", "library_ms": statistics.median(times)}
        row["read_ms"], row["peak_mib"] = measure(cli, [path], runs)
        rows.append(row)
    return rows


if __name__ == "__main__":
    main()
