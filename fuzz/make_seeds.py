#!/usr/bin/env python3
"""Writes the small seed corpora of the fuzz targets (fuzz/seeds/<target>/) from the real files in
../shared/data: headers and the first records of each file, with sizes cut down so that one run of a
target takes microseconds. Run again after changing it: python3 fuzz/make_seeds.py [shared-data-dir]."""
import base64
import gzip
import os
import struct
import sys
import zlib

here = os.path.dirname(os.path.abspath(__file__))
data = sys.argv[1] if len(sys.argv) > 1 else os.path.join(here, "..", "..", "shared", "data")
out = os.path.join(here, "seeds")


def put(target, name, content):
    os.makedirs(os.path.join(out, target), exist_ok=True)
    if isinstance(content, str):
        content = content.encode("latin-1")
    with open(os.path.join(out, target, name), "wb") as f:
        f.write(content)


def text(name):
    path = os.path.join(data, name)
    raw = gzip.open(path).read() if name.endswith(".gz") else open(path, "rb").read()
    return raw.decode("latin-1")


def nrrd_header(name):
    raw = open(os.path.join(data, name), "rb").read()
    end = raw.find(b"\n\n")
    return raw[: end + 1].decode("latin-1"), raw[end + 2 :]


def set_field(header, field, value):
    lines = [l for l in header.splitlines() if not l.startswith(field + ":")]
    return "\n".join(lines + [f"{field}: {value}"]) + "\n"


# --- NRRD: detached headers naming the fuzzer's 4096-byte d.raw, attached gzip/raw/ascii/hex data.
for name, sizes in (("headsq.nhdr", "16 16 8"), ("neghip.nhdr", "16 16 16")):
    h = open(os.path.join(data, name)).read()
    h = set_field(set_field(h, "sizes", sizes), "data file", "d.raw")
    put("nrrd", name, h)
for name, typ in (("chest_ct.nrrd", 1), ("cranium_ct.nrrd", 2)):
    h, payload = nrrd_header(name)
    voxels = zlib.decompressobj(31).decompress(payload, 8 * 8 * 6 * typ)[: 8 * 8 * 6 * typ]
    h = set_field(h, "sizes", "8 8 6")
    put("nrrd", name.replace(".nrrd", "_gzip.nrrd"), h.encode() + b"\n" + gzip.compress(voxels, mtime=0))
    put("nrrd", name.replace(".nrrd", "_raw.nrrd"), set_field(h, "encoding", "raw").encode() + b"\n" + voxels)
    if typ == 1:
        put("nrrd", "chest_ascii.nrrd", set_field(set_field(h, "encoding", "ascii"), "sizes", "4 4 2") + "\n" +
            " ".join(str(b) for b in voxels[:32]) + "\n")
        put("nrrd", "chest_hex.nrrd", set_field(set_field(h, "encoding", "hex"), "sizes", "4 4 2") + "\n" + voxels[:32].hex() + "\n")
put("nrrd", "space.nrrd",
    "NRRD0005\n# a comment\ncontent: test\ntype: float\ndimension: 3\nspace: left-posterior-superior\n"
    "sizes: 2 2 2\nspace directions: (1,0,0) (0,1.5,0) (0,0,2)\nkinds: domain domain domain\n"
    "labels: \"x\" \"y\" \"z\"\nspace units: \"mm\" \"mm\" \"mm\"\nspace origin: (0.5,-1,2)\n"
    "measurement frame: (1,0,0) (0,1,0) (0,0,1)\nendian: big\nline skip: 0\nbyte skip: 0\n"
    "key:=value\nencoding: raw\n\n" + "\0\0\0\0" * 8)

# --- Raw: the fuzz target takes its options from the input's last bytes (FuzzedDataProvider) and the
# file from the first: slices of the real raw volumes.
put("raw", "headsq.bin", open(os.path.join(data, "headsq.raw"), "rb").read()[40000:40600])
put("raw", "neghip.bin", open(os.path.join(data, "neghip.raw"), "rb").read()[140000:140300])

# --- NIfTI-1: chris_t1's header with a 4x4x4 grid, as uint8, int16 and float32, plain and gzip.
hdr = bytearray(gzip.open(os.path.join(data, "chris_t1.nii.gz")).read(352))
for code, bits, fmt, tag in ((2, 8, "B", "u8"), (4, 16, "h", "i16"), (16, 32, "f", "f32")):
    h = bytearray(hdr)
    struct.pack_into("<8h", h, 40, 3, 4, 4, 4, 1, 1, 1, 1)
    struct.pack_into("<hh", h, 70, code, bits)
    struct.pack_into("<f", h, 108, 352.0)
    body = struct.pack("<64" + fmt, *[(i * 7) % 100 for i in range(64)])
    put("nifti", f"t1_{tag}.nii", bytes(h) + body)
    if tag == "i16":
        put("nifti", f"t1_{tag}.nii.gz", gzip.compress(bytes(h) + body, mtime=0))

# --- DICOM: one CT slice's header (with its sequence) over an 8x8 crop of its pixels, in the transfer
# syntaxes pydicom writes (implicit and explicit VR little endian, explicit big endian, RLE), as signed
# rescaled and 8-bit images, and in JPEG lossless, JPEG-LS and JPEG 2000 when gdcmconv is there (JPEG
# 2000 also signed, 8-bit, lossy and wrapped in a JP2 file).
def dicom_seeds():
    import shutil
    import subprocess
    import tempfile
    import pydicom
    from pydicom.uid import ExplicitVRBigEndian, ExplicitVRLittleEndian, RLELossless

    def ct(size=8):
        ds = pydicom.dcmread(os.path.join(data, "dicom_pancreas_ct", "1-070.dcm"))
        pixels = ds.pixel_array[250:250 + size, 250:250 + size].copy()
        ds.Rows, ds.Columns = pixels.shape
        ds.PixelData = pixels.tobytes()
        return ds, pixels

    def save(ds, name, syntax=None, seed=True):
        path = os.path.join(tempfile.gettempdir(), "penumbra_seed_" + name)
        if syntax is not None:
            ds.file_meta.TransferSyntaxUID = syntax
            ds.is_implicit_VR, ds.is_little_endian = False, syntax != ExplicitVRBigEndian
        ds.save_as(path, write_like_original=False)
        if seed:
            put("dicom", name, open(path, "rb").read())
        return path

    ds, _ = ct()
    plain = save(ds, "ct_implicit.dcm")
    ds, pixels = ct()
    save(ds, "ct_explicit.dcm", ExplicitVRLittleEndian)
    ds.PixelData = pixels.astype(">u2").tobytes()
    save(ds, "ct_big_endian.dcm", ExplicitVRBigEndian)
    ds, pixels = ct()
    ds.compress(RLELossless, pixels)
    save(ds, "ct_rle.dcm")
    ds, pixels = ct()
    ds.PixelRepresentation, ds.BitsStored, ds.HighBit, ds.RescaleSlope = 1, 16, 15, "0.5"
    ds.PixelData = (pixels.astype("int16") - 1500).tobytes()
    signed = save(ds, "signed_rescaled.dcm", ExplicitVRLittleEndian)
    ds, pixels = ct()
    ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.RescaleIntercept = 8, 8, 7, "0"
    ds.PixelData = (pixels // 16).astype("uint8").tobytes()
    save(ds, "u8.dcm", ExplicitVRLittleEndian)
    ds, pixels = ct(16)  # 16x16: gdcmconv 3.0.21 crashes compressing an 8x8 8-bit image in JPEG 2000
    ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.RescaleIntercept = 8, 8, 7, "0"
    ds.PixelData = (pixels // 16).astype("uint8").tobytes()
    u8 = save(ds, "u8_16.dcm", ExplicitVRLittleEndian, seed=False)
    if shutil.which("gdcmconv"):
        def gdcmconv(source, name, *flags):
            out = os.path.join(tempfile.gettempdir(), "penumbra_seed_" + name)
            subprocess.run(["gdcmconv", *flags, source, out], check=True, capture_output=True)
            put("dicom", name, open(out, "rb").read())
            return out

        for flag in ("jpeg", "jpegls", "j2k"):
            j2k = gdcmconv(plain, "ct_%s.dcm" % flag, "--" + flag)
        gdcmconv(signed, "signed_j2k.dcm", "--j2k")
        gdcmconv(u8, "u8_j2k.dcm", "--j2k")
        gdcmconv(plain, "ct_j2k_lossy.dcm", "--j2k", "--lossy", "--irreversible", "-r", "4")
        # The codestream in a JP2 file (signature, file type, header and codestream boxes), as some
        # writers store it.
        from pydicom.encaps import decode_data_sequence, encapsulate
        ds = pydicom.dcmread(j2k)
        codestream = decode_data_sequence(ds.PixelData)[0]

        def box(kind, content):
            return struct.pack(">I", 8 + len(content)) + kind + content

        ihdr = struct.pack(">IIHBBBB", ds.Rows, ds.Columns, 1, ds.BitsStored - 1, 7, 0, 0)
        jp2 = (box(b"jP  ", b"\r\n\x87\n") + box(b"ftyp", b"jp2 \0\0\0\0jp2 ") +
               box(b"jp2h", box(b"ihdr", ihdr) + box(b"colr", b"\x01\0\0\0\0\0\x11")) + box(b"jp2c", codestream))
        ds.PixelData = encapsulate([jp2])
        ds.save_as(os.path.join(tempfile.gettempdir(), "penumbra_seed_ct_jp2.dcm"))
        put("dicom", "ct_jp2.dcm", open(os.path.join(tempfile.gettempdir(), "penumbra_seed_ct_jp2.dcm"), "rb").read())


dicom_seeds()

# --- PDB: header records (REMARK 350, SSBOND, LINK, CISPEP, HELIX, SHEET, CRYST1) and the first atoms.
def pdb_seed(name, atoms, keep_remark350=40):
    lines = text(name).splitlines()
    head, n350, body = [], 0, []
    for l in lines:
        rec = l[:6]
        if l.startswith("REMARK 350"):
            if n350 < keep_remark350:
                head.append(l)
            n350 += 1
        elif rec in ("HEADER", "TITLE ", "CRYST1", "SCALE1", "ORIGX1", "MTRIX1") and len(head) < 80:
            head.append(l)
        elif rec in ("SSBOND", "LINK  ", "CISPEP", "HELIX ", "SHEET ") and sum(h[:6] == rec for h in head) < 2:
            head.append(l)
        elif rec in ("ATOM  ", "HETATM") and len(body) < atoms:
            body.append(l)
    return "\n".join(head + body + ["TER", "END"]) + "\n"

put("pdb", "1tii.pdb", pdb_seed("1tii.pdb", 40))
put("pdb", "1af6.pdb", pdb_seed("1af6.pdb", 30))
put("pdb", "1m4x.pdb", pdb_seed("1m4x.pdb.gz", 30, keep_remark350=16))
put("pdb", "3j6r.pdb.gz", gzip.compress(pdb_seed("3j6r.pdb.gz", 20, keep_remark350=16).encode(), mtime=0))

# --- mmCIF: the assembly categories (three operators) and the first atom_site rows.
def cif_seed(name, atoms):
    sections, cur = [], []
    for l in text(name).splitlines():
        if l.strip() == "#":
            sections.append(cur)
            cur = []
        else:
            cur.append(l.rstrip())
    sections.append(cur)
    keep = []
    for lines in sections:
        body = "\n".join(lines)
        if not lines:
            continue
        first = lines[1] if lines[0] == "loop_" and len(lines) > 1 else lines[0]
        if first.startswith("data_"):
            keep.append(lines[0])
        elif first.startswith(("_pdbx_struct_assembly", "_cell.", "_symmetry.", "_struct_conn.")):
            if lines[0] == "loop_":
                tags = [l for l in lines if l.startswith("_") or l == "loop_"]
                rows = [l for l in lines if not (l.startswith("_") or l == "loop_")]
                keep.append("\n".join(tags + rows[:6]))
            else:
                keep.append(body)
        elif first.startswith("_atom_site."):
            tags = [l for l in lines if l.startswith("_") or l == "loop_"]
            rows = [l for l in lines if not (l.startswith("_") or l == "loop_")]
            keep.append("\n".join(tags + rows[:atoms]))
    return "\n#\n".join(keep) + "\n#\n"

put("mmcif", "4yvs.cif", cif_seed("4yvs.cif.gz", 40))
put("mmcif", "3sn6.cif.gz", gzip.compress(cif_seed("3sn6.cif.gz", 20).encode(), mtime=0))

# --- GRO: the first atoms with a matching count, with and without velocities.
def gro_seed(name, atoms):
    lines = text(name).splitlines()
    return "\n".join([lines[0], "%5d" % atoms] + lines[2 : 2 + atoms] + [lines[-1]]) + "\n"

put("gro", "md_1tii_chainD.gro", gro_seed("md_1tii_chainD.gro", 20))
put("gro", "bace1_dppc.gro", gro_seed("bace1_dppc.gro.gz", 20))

# --- XYZ: one frame of graphene, two frames of the MD trajectory.
def xyz_seed(name, atoms, frames):
    lines = text(name).splitlines()
    n, out_lines, pos = int(lines[0]), [], 0
    for _ in range(frames):
        out_lines += [str(atoms), lines[pos + 1]] + lines[pos + 2 : pos + 2 + atoms]
        pos += n + 2
    return "\n".join(out_lines) + "\n"

put("xyz", "graphene.xyz", xyz_seed("graphene.xyz", 24, 1))
put("xyz", "md_1tii.xyz", xyz_seed("md_1tii_chainD_20frames.xyz.gz", 12, 2))

# --- Scene files: every scenes/*.json, some with --set overrides after NUL bytes.
scenes = os.path.join(here, "..", "scenes")
for i, name in enumerate(sorted(os.listdir(scenes))):
    s = open(os.path.join(scenes, name), "rb").read()
    sets = [b"shadows.technique=cssm", b"lights.0.intensity=2", b"camera.width=8"][: i % 4]
    put("scene", name, b"\0".join([s] + sets))

# --- XTC and DCD trajectories: a few atoms of the MD run in two frames (MDAnalysis' writers when it is
# installed: compressed XTC of 40 atoms, so the bit-packed runs of water are there), and files made here
# byte by byte: an XTC of 3 atoms (stored as plain floats) and DCDs in both byte orders.
def xtc_plain(atoms, frames):
    b = b""
    for k in range(frames):
        b += struct.pack(">iiif", 1995, atoms, 100 * k, 0.2 * k) + struct.pack(">9f", 6.4, 0, 0, 0, 6.4, 0, 3.2, 3.2, 4.5)
        b += struct.pack(">i", atoms) + struct.pack(">%df" % (3 * atoms), *[0.1 * (i + k) for i in range(3 * atoms)])
    return b

def dcd_bytes(atoms, frames, endian):
    rec = lambda payload: struct.pack(endian + "i", len(payload)) + payload + struct.pack(endian + "i", len(payload))
    icntrl = [frames, 0, 100, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 24]
    head = b"CORD" + struct.pack(endian + "9i", *icntrl[:9]) + struct.pack(endian + "f", 0.0409) + struct.pack(endian + "10i", *icntrl[10:])
    b = rec(head) + rec(struct.pack(endian + "i", 1) + b"seed".ljust(80)) + rec(struct.pack(endian + "i", atoms))
    for k in range(frames):
        b += rec(struct.pack(endian + "6d", 64.0, 0.0, 64.0, 0.5, 0.5, 64.0))
        for d in range(3):
            b += rec(struct.pack(endian + "%df" % atoms, *[float(i + k + d) for i in range(atoms)]))
    return b

put("xtc", "plain3.xtc", xtc_plain(3, 2))
put("dcd", "le.dcd", dcd_bytes(5, 2, "<"))
put("dcd", "be.dcd", dcd_bytes(5, 2, ">"))
try:
    import tempfile
    import warnings
    warnings.simplefilter("ignore")
    import MDAnalysis as mda
    u = mda.Universe(os.path.join(data, "md_1tii_chainD.gro"), os.path.join(data, "md_1tii_chainD_20frames.dcd"))
    sel = u.atoms[1470:1510]  # water: runs of close atoms
    with tempfile.TemporaryDirectory() as tmp:
        for ext in ("xtc", "dcd"):
            path = os.path.join(tmp, "md." + ext)
            with mda.Writer(path, sel.n_atoms) as w:
                for ts in u.trajectory[:2]:
                    w.write(sel)
            put(ext, "md_1tii_water40." + ext, open(path, "rb").read())
except ImportError:
    pass

# --- TIFF: crops of the staged stacks as ImageJ files (tifffile), a tiled deflate float32 stack, RGB
# pages contiguous and planar, and LZW/PackBits pages (PIL, through its libtiff).
try:
    import io
    import numpy as np
    import tifffile
    embryo = tifffile.imread(os.path.join(data, "arabidopsis_embryo.tif"))[50:53, 50:60, 50:62]
    nucleus = tifffile.imread(os.path.join(data, "nucleus_conf_wf.tif"))[20:23, :, 60:65, 60:66]
    def tif(name, array, **kw):
        buf = io.BytesIO()
        tifffile.imwrite(buf, array, **kw)
        put("tiff", name, buf.getvalue())
    tif("embryo_imagej.tif", embryo, imagej=True, byteorder=">", metadata={"axes": "ZYX"})
    tif("nucleus_hyperstack.tif", nucleus, imagej=True, byteorder=">", resolution=(1.953591, 1.953591),
        metadata={"spacing": 0.4994126, "unit": "micron", "axes": "ZCYX"})
    ramp = (np.arange(2 * 18 * 20, dtype=np.float32).reshape(2, 18, 20) - 100) * 0.25
    tif("float_tiled_deflate.tif", ramp, tile=(16, 16), compression="zlib", resolution=(1e4, 1e4, "CENTIMETER"))
    rgb = (np.arange(2 * 3 * 4 * 3) * 7 % 256).astype(np.uint8).reshape(2, 3, 4, 3)
    tif("rgb_contig.tif", rgb, photometric="rgb", planarconfig="contig")
    tif("rgb_planar.tif", rgb.transpose(0, 3, 1, 2).copy(), photometric="rgb", planarconfig="separate")
    tif("int16_pages.tif", (np.arange(3 * 4 * 5, dtype=np.int16).reshape(3, 4, 5) * 997 - 30000), photometric="minisblack")
except ImportError:
    pass
try:
    import io
    from PIL import Image
    frames = [Image.frombytes("L", (12, 10), bytes(embryo[k].tobytes())) for k in range(3)]
    for compression in ("tiff_lzw", "packbits"):
        buf = io.BytesIO()
        frames[0].save(buf, format="TIFF", save_all=True, append_images=frames[1:], compression=compression)
        put("tiff", "embryo_%s.tif" % compression.replace("tiff_", ""), buf.getvalue())
except (ImportError, NameError):
    pass

# --- VTK image data: an 8x8x4 crop of headsq as .vti (appended raw, appended base64+zlib with the header
# encoded apart as VTK does, inline base64 with a 64-bit header, ascii) and as legacy .vtk (BINARY with
# VTK 9's METADATA trailer, and ASCII).
head = open(os.path.join(data, "headsq.raw"), "rb").read()
crop = b"".join(head[((z + 40) * 64 + y + 28) * 128 + 56:((z + 40) * 64 + y + 28) * 128 + 72] for z in range(4) for y in range(8))
def vti(root, array, appended=None, encoding="raw"):
    s = ('<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" %s>\n'
         '  <ImageData WholeExtent="0 7 0 7 0 3" Origin="0 0 0" Spacing="3.2 3.2 1.5" Direction="1 0 0 0 1 0 0 0 1">\n'
         '    <Piece Extent="0 7 0 7 0 3">\n      <PointData Scalars="headsq">\n        %s\n      </PointData>\n'
         '      <CellData>\n      </CellData>\n    </Piece>\n  </ImageData>\n' % (root, array)).encode()
    if appended is not None:
        s += b'  <AppendedData encoding="' + encoding.encode() + b'">\n   _' + appended + b"\n  </AppendedData>\n"
    return s + b"</VTKFile>\n"
appended = '<DataArray type="Int16" Name="headsq" format="appended" RangeMin="0" RangeMax="3926" offset="0"/>'
put("vti", "headsq_appended_raw.vti", vti('header_type="UInt32"', appended, struct.pack("<I", len(crop)) + crop))
blocks = [crop[i:i + 200] for i in range(0, len(crop), 200)]
packed = [zlib.compress(b, 5) for b in blocks]
table = struct.pack("<%dI" % (3 + len(packed)), len(packed), 200, len(crop) % 200, *[len(p) for p in packed])
put("vti", "headsq_base64_zlib.vti", vti('header_type="UInt32" compressor="vtkZLibDataCompressor"', appended,
                                        base64.b64encode(table) + base64.b64encode(b"".join(packed)), "base64"))
put("vti", "headsq_binary_uint64.vti", vti('header_type="UInt64"', '<DataArray type="Int16" Name="headsq" format="binary">' +
                                           base64.b64encode(struct.pack("<Q", len(crop)) + crop).decode() + "</DataArray>"))
values = struct.unpack("<%dh" % (len(crop) // 2), crop)
put("vti", "headsq_ascii.vti", vti("", '<DataArray type="Int16" Name="headsq" format="ascii">' +
                                   " ".join(map(str, values[:64])) + "</DataArray>").replace(b"0 7 0 7 0 3", b"0 7 0 7 0 0"))
legacy = ("# vtk DataFile Version 5.1\nheadsq crop\n%s\nDATASET STRUCTURED_POINTS\nDIMENSIONS 8 8 4\nSPACING 3.2 3.2 1.5\n"
          "ORIGIN 0 0 0\nPOINT_DATA 256\nSCALARS headsq short\nLOOKUP_TABLE default\n")
put("vtk", "headsq_binary.vtk", (legacy % "BINARY").encode() + struct.pack(">%dh" % len(values), *values) + b"\nMETADATA\nINFORMATION 0\n\n")
put("vtk", "headsq_ascii.vtk", (legacy % "ASCII").replace("8 8 4", "8 8 1").replace("256", "64").replace("short", "float") +
    " ".join("%g" % (v * 0.5) for v in values[:64]) + "\n")
