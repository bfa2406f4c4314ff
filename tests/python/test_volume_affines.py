"""Every volume in its place (docs/volume-formats.md, "World frame"): the same voxels stored with
flipped, swapped and rotated index-to-world affines — NIfTI written by nibabel (FSL's flipped x, sform
over qform, qform alone), NRRD `space directions` in RAS and in LPS, VTI `Direction` — load onto the
same canonical grid (LPS +x, +y, +z) and render byte for byte like those voxels given on that grid; an
oblique rotation is resampled and renders within 35 dB of the canonical volume seen by a camera turned
with it; bad affines are errors naming the file; a DICOM series whose positions were rounded to two
decimals gets its spacing from a fit through them.

    PYTHONPATH=build/release/python PENUMBRA_CLI=build/release/penumbra /usr/bin/python3 -m pytest -q tests/python/test_volume_affines.py
"""
import math
import os
import struct
import subprocess

import numpy as np
import pytest

import penumbra

nib = pytest.importorskip("nibabel")

CLI = os.environ.get("PENUMBRA_CLI", "penumbra")
ROOT = os.environ.get("PENUMBRA_ROOT", os.path.join(os.path.dirname(__file__), "..", ".."))
DATA = os.environ.get("PENUMBRA_DATA_DIR", os.path.join(ROOT, "..", "shared", "data"))

DIMS = (24, 20, 16)                      # the canonical grid, x y z (LPS)
SPACING = (1.0, 1.5, 2.0)
ORIGIN = (10.0, -20.0, 30.0)
RAS = np.diag([-1.0, -1.0, 1.0, 1.0])   # LPS <-> RAS (its own inverse)
TF = [[0.0, 0, 0, 0, 0.0], [0.3, 0.9, 0.5, 0.2, 0.05], [1.0, 1.0, 0.95, 0.8, 0.6]]


def canonical():
    """Smooth voxels with no symmetry (three blobs of different sizes and a ramp), indexed [x, y, z]."""
    x, y, z = np.meshgrid(*[np.arange(n, dtype=np.float64) for n in DIMS], indexing="ij")
    v = np.zeros(DIMS)
    for (cx, cy, cz, r, a) in [(7, 6, 5, 3.0, 1.0), (16, 13, 9, 4.5, 0.7), (12, 5, 11, 2.0, 0.9)]:
        v += a * np.exp(-((x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2) / (2 * r * r))
    v += 0.15 * x / DIMS[0] * (z / DIMS[2])
    return v.astype(np.float32)


def lps_affine():
    a = np.diag(list(SPACING) + [1.0])
    a[:3, 3] = ORIGIN
    return a


def stored(canon, perm, flips):
    """The voxels as a file stores them: file axis a holds canonical axis perm[a], reversed when flips[a];
    and the file's LPS affine that puts each back where it was."""
    f = np.transpose(canon, perm)
    m = np.zeros((4, 4))
    m[3, 3] = 1
    for a in range(3):
        if flips[a]:
            f = np.flip(f, a)
            m[perm[a], a], m[perm[a], 3] = -1, DIMS[perm[a]] - 1
        else:
            m[perm[a], a] = 1
    return np.ascontiguousarray(f), lps_affine() @ m


CASES = {  # name: (perm, flips)
    "plain": ((0, 1, 2), (False, False, False)),
    "fsl_flipped_x": ((0, 1, 2), (True, False, False)),
    "swapped_xy": ((1, 0, 2), (False, False, False)),
    "rotated_90_about_z": ((1, 0, 2), (False, True, False)),
    "permuted_and_flipped": ((2, 0, 1), (True, False, True)),
}


def write_nifti(path, voxels, lps, how):
    img = nib.Nifti1Image(voxels, None)
    ras = RAS @ lps
    if how == "sform":  # the sform wins over a wrong qform
        img.set_qform(np.diag([3.0, 3.0, 3.0, 1.0]), code=1)
        img.set_sform(ras, code=2)
    else:  # sform_code 0: the qform
        img.set_sform(None, code=0)
        img.set_qform(ras, code=1)
    nib.save(img, path)
    back = nib.load(path)
    assert np.allclose(back.affine, ras, atol=1e-3)  # what nibabel reads is the affine meant (a qform's float32 quaternion: 5e-4)
    assert int(back.header["sform_code"]) == (2 if how == "sform" else 0)


def write_nrrd(path, voxels, lps, space):
    a = RAS @ lps if space == "right-anterior-superior" else lps
    dirs = " ".join("(" + ",".join(repr(float(a[r, c])) for r in range(3)) + ")" for c in range(3))
    header = (f"NRRD0004\ntype: float\ndimension: 3\nspace: {space}\nsizes: {' '.join(map(str, voxels.shape))}\n"
              f"space directions: {dirs}\nspace origin: ({','.join(repr(float(a[r, 3])) for r in range(3))})\n"
              "endian: little\nencoding: raw\n\n")
    with open(path, "wb") as f:
        f.write(header.encode() + voxels.astype("<f4").ravel(order="F").tobytes())


def write_vti(path, voxels, lps):
    spacing = [float(np.linalg.norm(lps[:3, c])) for c in range(3)]
    direction = " ".join(repr(float(lps[r, c] / spacing[c])) for r in range(3) for c in range(3))  # row-major
    n = voxels.shape
    values = " ".join(repr(float(v)) for v in voxels.ravel(order="F"))
    text = (f'<?xml version="1.0"?>\n<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian">\n'
            f'  <ImageData WholeExtent="0 {n[0] - 1} 0 {n[1] - 1} 0 {n[2] - 1}" Origin="{" ".join(repr(float(x)) for x in lps[:3, 3])}" '
            f'Spacing="{" ".join(map(repr, spacing))}" Direction="{direction}">\n'
            f'    <Piece Extent="0 {n[0] - 1} 0 {n[1] - 1} 0 {n[2] - 1}">\n      <PointData Scalars="s">\n'
            f'        <DataArray type="Float32" Name="s" format="ascii">{values}</DataArray>\n'
            '      </PointData>\n    </Piece>\n  </ImageData>\n</VTKFile>\n')
    with open(path, "w") as f:
        f.write(text)


def camera(turn=0.0):
    """A camera looking at the grid's centre, its eye turned by `turn` radians about the vertical through it."""
    centre = np.array(ORIGIN) + 0.5 * np.array([(n - 1) * s for n, s in zip(DIMS, SPACING)])
    offset = np.array([30.0, -45.0, 25.0])
    c, s = math.cos(turn), math.sin(turn)
    eye = centre + np.array([c * offset[0] - s * offset[1], s * offset[0] + c * offset[1], offset[2]])
    return {"eye": eye.tolist(), "target": centre.tolist(), "up": [0, 0, 1], "fov_deg": 40, "width": 64, "height": 48}


def document(turn=0.0):
    c, s = math.cos(turn), math.sin(turn)
    light = [0.4, 0.3, -1.0]
    return {"camera": camera(turn), "background": [0.1, 0.1, 0.12], "shadows": {"technique": "shadow_map"},
            "lights": [{"type": "directional", "direction": [c * light[0] - s * light[1], s * light[0] + c * light[1], light[2]]}]}


def render_file(path, turn=0.0):
    doc = document(turn)
    doc["volumes"] = [{"file": path, "transfer_function": {"points": TF}}]
    return np.asarray(penumbra.Renderer(penumbra.Scene(doc)).render())


def render_canonical(turn=0.0):
    scene = penumbra.Scene(document(turn))
    scene.add_volume(np.ascontiguousarray(canonical().transpose(2, 1, 0)), spacing=tuple(reversed(SPACING)),
                     origin=tuple(reversed(ORIGIN)), transfer_function={"points": TF})
    return np.asarray(penumbra.Renderer(scene).render())


@pytest.fixture(scope="module")
def reference():
    image = render_canonical()
    assert image[..., :3].std() > 0.02  # the volume is in view
    return image


def expect_canonical(path, reference):
    v = penumbra.read_volume(path)
    assert np.array_equal(v.array, canonical().transpose(2, 1, 0)), "the voxels are not on the canonical grid"
    assert v.spacing == pytest.approx(tuple(reversed(SPACING)), abs=1e-6)
    assert v.origin == pytest.approx(tuple(reversed(ORIGIN)), abs=1e-4)
    assert np.array_equal(render_file(path), reference), "renders unlike the same voxels on the canonical grid"
    return v


@pytest.mark.parametrize("how", ["sform", "qform"])
@pytest.mark.parametrize("case", list(CASES))
def test_nifti_written_by_nibabel_renders_like_the_canonical_grid(tmp_path, reference, case, how):
    voxels, lps = stored(canonical(), *CASES[case])
    path = str(tmp_path / f"{case}_{how}.nii.gz")
    write_nifti(path, voxels, lps, how)
    v = expect_canonical(path, reference)
    assert np.allclose(np.array(v.info["affine"]), lps[:3], atol=1e-3)
    assert any(("sform" if how == "sform" else "qform") in n for n in v.info["notes"])


@pytest.mark.parametrize("space", ["right-anterior-superior", "left-posterior-superior"])
@pytest.mark.parametrize("case", ["fsl_flipped_x", "rotated_90_about_z", "permuted_and_flipped"])
def test_nrrd_space_directions_render_like_the_canonical_grid(tmp_path, reference, case, space):
    voxels, lps = stored(canonical(), *CASES[case])
    path = str(tmp_path / f"{case}.nrrd")
    write_nrrd(path, voxels, lps, space)
    expect_canonical(path, reference)


@pytest.mark.parametrize("case", ["fsl_flipped_x", "swapped_xy", "permuted_and_flipped"])
def test_vti_direction_renders_like_the_canonical_grid(tmp_path, reference, case):
    voxels, lps = stored(canonical(), *CASES[case])
    path = str(tmp_path / f"{case}.vti")
    write_vti(path, voxels, lps)
    expect_canonical(path, reference)


def test_an_oblique_rotation_is_resampled_and_renders_like_the_turned_view(tmp_path):
    turn = math.radians(30)
    c, s = math.cos(turn), math.sin(turn)
    centre = np.array(ORIGIN) + 0.5 * np.array([(n - 1) * sp for n, sp in zip(DIMS, SPACING)])
    rotate = np.eye(4)
    rotate[:2, :2] = [[c, -s], [s, c]]
    about = np.eye(4)
    about[:3, 3] = centre
    lps = about @ rotate @ np.linalg.inv(about) @ lps_affine()  # the grid turned 30° about the vertical through its centre
    path = str(tmp_path / "oblique.nii.gz")
    write_nifti(path, canonical(), lps, "sform")
    v = penumbra.read_volume(path)
    assert any("resampled trilinearly" in n and "30 degrees" in n for n in v.info["notes"]), v.info["notes"]
    assert v.spacing == pytest.approx((1.0, 1.0, 1.0))
    # The turned volume seen by a camera (and light) turned with it looks like the canonical one seen
    # by the unturned camera; had the rotation been dropped, it would look like the canonical one seen
    # by the turned camera instead.
    turned = render_file(path, turn)
    psnr = penumbra.compare(turned, render_canonical())["psnr"]
    psnr_dropped = penumbra.compare(turned, render_canonical(turn))["psnr"]
    print(f"oblique: {psnr:.1f} dB from the canonical view, {psnr_dropped:.1f} dB from the view of the rotation dropped")
    assert psnr > 35, f"the resampled volume is {psnr:.1f} dB from the canonical one seen turned"
    assert psnr_dropped < psnr - 5, "the view does not tell a turned volume from an unturned one"


def test_nifti_without_sform_or_qform_takes_nibabels_base_affine(tmp_path):
    voxels = canonical()
    img = nib.Nifti1Image(voxels, None)
    img.header.set_zooms(SPACING)
    path = str(tmp_path / "no_codes.nii")
    nib.save(img, path)
    back = nib.load(path)
    assert int(back.header["sform_code"]) == 0 and int(back.header["qform_code"]) == 0
    v = penumbra.read_volume(path)
    assert np.allclose(np.array(v.info["affine"]), (RAS @ back.affine)[:3], atol=1e-6)  # x flipped in RAS: y in LPS
    assert np.array_equal(v.array, np.flip(voxels, 1).transpose(2, 1, 0))
    assert any("base affine" in n for n in v.info["notes"])


def test_an_oblique_grid_too_large_to_resample_is_an_error(tmp_path):
    voxels, _ = stored(canonical()[:2, :2, :2].copy(), (0, 1, 2), (False, False, False))
    lps = np.eye(4)
    lps[:3, :3] = [[707.1, -0.0007071, 0], [707.1, 0.0007071, 0], [0, 0, 1]]  # 1000 mm and 0.001 mm, turned 45°
    path = str(tmp_path / "huge_oblique.nrrd")
    write_nrrd(path, voxels, lps, "left-posterior-superior")
    # 707108 x 707108 x 1001 voxels: 6e13 times the file's 8, refused before its size is even counted
    # (the 8 GiB cap is for files whose own grid is large: tests/test_fuzz_findings.cpp)
    with pytest.raises(penumbra.Error, match=r"huge_oblique\.nrrd.*resampled onto an axis-aligned grid of 707108x707108x1001 voxels "
                                             r".* times its own 2x2x2 \(at most 64 times"):
        penumbra.read_volume(path)


def test_info_prints_the_affine(tmp_path):
    voxels, lps = stored(canonical(), *CASES["fsl_flipped_x"])
    path = str(tmp_path / "flipped.nii.gz")
    write_nifti(path, voxels, lps, "sform")
    out = subprocess.run([CLI, "info", path], capture_output=True, text=True, check=True).stdout
    line = next(l for l in out.splitlines() if l.startswith("affine"))
    assert "[-1 0 0 33; 0 1.5 0 -20; 0 0 2 30]" in line, line
    assert "LPS" in line
    assert any(l.startswith("orientation") and "x = -i" in l for l in out.splitlines())


def test_singular_and_nan_affines_are_errors_naming_the_file(tmp_path):
    voxels, lps = stored(canonical(), *CASES["plain"])
    singular = lps.copy()
    singular[:3, 1] = singular[:3, 0]  # two columns alike
    path = str(tmp_path / "singular.nii")
    write_nifti(path, voxels, singular, "sform")
    with pytest.raises(penumbra.Error, match=r"singular\.nii.*singular"):
        penumbra.read_volume(path)
    path = str(tmp_path / "nan.nii")
    write_nifti(path, voxels, lps, "sform")
    with open(path, "r+b") as f:  # srow_x[1] (bytes 280 + 4)
        f.seek(284)
        f.write(struct.pack("<f", float("nan")))
    with pytest.raises(penumbra.Error, match=r"nan\.nii.*not finite"):
        penumbra.read_volume(path)


def test_dicom_positions_rounded_to_two_decimals_give_the_fitted_spacing(tmp_path):
    pydicom = pytest.importorskip("pydicom")
    folder = os.path.join(DATA, "dicom_pancreas_ct")
    if not os.path.isdir(folder):
        pytest.skip(f"missing data: {folder} not found")
    names = sorted(os.listdir(folder))[:40]
    for k, name in enumerate(names):  # 0.625 mm slices, positions written -50.00, -49.38, -48.75, ...
        ds = pydicom.dcmread(os.path.join(folder, name))
        ds.ImageOrientationPatient = [1, 0, 0, 0, 1, 0]
        ds.ImagePositionPatient = [-120.0, -130.0, f"{-50 + 0.625 * k:.2f}"]
        ds.SliceThickness = 0.625
        ds.save_as(str(tmp_path / f"s{k:03d}.dcm"))
    gaps = np.diff([round(-50 + 0.625 * k, 2) for k in range(40)])
    assert np.median(gaps) == pytest.approx(0.63)  # what the median gap would have given
    v = penumbra.read_volume(str(tmp_path))
    assert v.array.shape[0] == 40
    assert v.spacing[0] == pytest.approx(0.625, abs=2e-4)
    assert v.origin[0] == pytest.approx(-50.0, abs=5e-3)
    assert any("least-squares fit" in n for n in v.info["notes"]), v.info["notes"]
