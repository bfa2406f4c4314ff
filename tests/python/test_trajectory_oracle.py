"""penumbra's trajectory readers (src/penumbra/data/io/trajectory_*.cpp) against MDAnalysis as the oracle.

penumbra writes a frame's positions with `penumbra info --trajectory FILE --frame K --positions OUT.npy`;
MDAnalysis reads the same file. The staged GROMACS run (../shared/data, PROVENANCE.md "MD trajectory")
in every format, and small DCD/XTC files written here by MDAnalysis' writers (random coordinates; one
XTC of 5 atoms, which GROMACS stores uncompressed). Tolerances are the formats' precision: XTC and DCD
decode the same numbers (≤ 1e-3 Å; in practice 0), the text formats their printed decimals.

    PENUMBRA_CLI=build/release/penumbra /usr/bin/python3 -m pytest -q tests/python/test_trajectory_oracle.py
"""
import os
import re
import shutil
import subprocess
import warnings

import numpy as np
import pytest

mda = pytest.importorskip("MDAnalysis")

CLI = os.environ.get("PENUMBRA_CLI", "penumbra")
ROOT = os.environ.get("PENUMBRA_ROOT", os.path.join(os.path.dirname(__file__), "..", ".."))
DATA = os.environ.get("PENUMBRA_DATA_DIR", os.path.join(ROOT, "..", "shared", "data"))
GRO = os.path.join(DATA, "md_1tii_chainD.gro")

warnings.filterwarnings("ignore", category=DeprecationWarning)
warnings.filterwarnings("ignore", category=UserWarning)


def staged(name):
    path = os.path.join(DATA, name)
    if not os.path.exists(path):
        pytest.skip(f"missing data: {path} not found")
    return path


def cli_info(path, tmp_path, frame):
    """penumbra's frame `frame` of `path`: (positions (N, 3) float32, the printed fields)."""
    out = tmp_path / f"pos_{frame}.npy"
    result = subprocess.run([CLI, "info", "--trajectory", str(path), "--frame", str(frame), "--positions", str(out)],
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    fields = dict(re.findall(r"^(\w[\w ]*?)\s{2,}(.*)$", result.stdout, re.M))
    return np.load(out), fields


def frame_box(fields):
    box = fields["frame box"]
    return None if box == "none" else np.array([float(v) for v in box.split()[:6]])


def compare(tmp_path, traj, frames, tol, top=GRO, check_box=True):
    """Max |Δ| between penumbra's and MDAnalysis' positions over `frames`; boxes and times compared too.
    top=None: MDAnalysis' reader for the file alone (no topology needed)."""
    trajectory = mda.Universe(top, str(traj)).trajectory if top else mda.coordinates.core.reader(str(traj))
    worst = 0.0
    for k in frames:
        ts = trajectory[k]
        pos, fields = cli_info(traj, tmp_path, k)
        assert pos.shape == ts.positions.shape
        worst = max(worst, float(np.max(np.abs(pos.astype(np.float64) - ts.positions.astype(np.float64)))))
        t = float(re.match(r"\d+: time (\S+) ps", fields["frame"]).group(1))
        assert t == pytest.approx(ts.time, abs=1e-4)
        if check_box and ts.dimensions is not None:
            assert np.allclose(frame_box(fields), ts.dimensions, atol=1e-3)
    assert worst <= tol, f"{traj}: max |dx| {worst} > {tol}"
    return worst


def test_staged_xtc_matches_mdanalysis(tmp_path):
    src = staged("md_1tii_chainD.xtc")
    xtc = tmp_path / "md.xtc"  # MDAnalysis writes .xtc_offsets next to the file: use a copy
    shutil.copy(src, xtc)
    worst = compare(tmp_path, xtc, [0, 1, 7, 75, 149, 150], 1e-3)
    print(f"xtc max |dx| vs MDAnalysis: {worst}")
    assert worst == 0.0  # both decode the same integers and scale them alike in float32


def test_staged_dcd_matches_mdanalysis(tmp_path):
    dcd = staged("md_1tii_chainD_20frames.dcd")
    worst = compare(tmp_path, dcd, [0, 3, 19], 0.0)
    print(f"dcd max |dx| vs MDAnalysis: {worst}")


def test_staged_pdb_and_xyz_match_mdanalysis(tmp_path):
    staged("md_1tii_chainD.gro")
    # MDAnalysis 2.4's PDBReader ignores a CRYST1 before MODEL 1 (PROVENANCE.md): boxes not compared there.
    w_pdb = compare(tmp_path, staged("md_1tii_chainD_20frames.pdb.gz"), [0, 10, 19], 1e-6, check_box=False)
    w_xyz = compare(tmp_path, staged("md_1tii_chainD_20frames.xyz.gz"), [0, 19], 1e-6, check_box=False)
    print(f"pdb max |dx| vs MDAnalysis: {w_pdb}; xyz: {w_xyz}")


def test_info_reports_counts_times_and_box(tmp_path):
    xtc = tmp_path / "md.xtc"
    shutil.copy(staged("md_1tii_chainD.xtc"), xtc)
    result = subprocess.run([CLI, "info", str(xtc)], capture_output=True, text=True, check=True)
    assert re.search(r"^atoms\s+18182$", result.stdout, re.M)
    assert re.search(r"^frames\s+151$", result.stdout, re.M)
    assert re.search(r"^time\s+0 \.\. 30 ps", result.stdout, re.M)
    box = [float(v) for v in re.search(r"^box\s+(.*)$", result.stdout, re.M).group(1).split()[:6]]
    assert np.allclose(box, [64.008, 64.008, 64.008, 60, 60, 90], atol=1e-4)
    assert re.search(r"^memory\s+\d+ bytes", result.stdout, re.M)


def random_universe(n_atoms, seed):
    rng = np.random.default_rng(seed)
    u = mda.Universe.empty(n_atoms, trajectory=True)
    return u, rng


# 5 atoms: stored as plain floats; a span of 3·10⁵ Å: ranges above 2²⁴ ints, each coordinate in its own bits.
@pytest.mark.parametrize("n_atoms,span", [(50, 100.0), (5, 100.0), (300, 3e5)])
def test_xtc_written_by_mdanalysis(tmp_path, n_atoms, span):
    u, rng = random_universe(n_atoms, n_atoms)
    path = tmp_path / f"r{n_atoms}.xtc"
    with mda.Writer(str(path), n_atoms) as w:
        for k in range(5):
            u.atoms.positions = rng.uniform(-span / 2, span / 2, size=(n_atoms, 3)).astype(np.float32)
            u.dimensions = [40 + k, 50, 60, 90, 80 + k, 70]
            u.trajectory.ts.time = 0.5 * k
            w.write(u)
    worst = compare(tmp_path, path, range(5), 1e-3, top=None)
    print(f"generated xtc ({n_atoms} atoms, span {span} A) max |dx|: {worst}")


def test_dcd_written_by_mdanalysis(tmp_path):
    n_atoms = 50
    u, rng = random_universe(n_atoms, 7)
    path = tmp_path / "r.dcd"
    with mda.Writer(str(path), n_atoms, dt=0.5, nsavc=10, istart=20) as w:
        for k in range(5):
            u.atoms.positions = rng.uniform(-40, 60, size=(n_atoms, 3)).astype(np.float32)
            u.dimensions = [40 + k, 50, 60, 90, 80 + k, 70]
            w.write(u)
    worst = compare(tmp_path, path, range(5), 0.0, top=None)
    print(f"generated dcd max |dx|: {worst}")


def test_truncated_xtc_names_the_file_and_frame(tmp_path):
    data = open(staged("md_1tii_chainD.xtc"), "rb").read()
    cut = tmp_path / "cut.xtc"
    cut.write_bytes(data[:100000])  # frame 0 is about 66 kB: the cut is inside frame 1
    result = subprocess.run([CLI, "info", str(cut)], capture_output=True, text=True)
    assert result.returncode != 0
    assert str(cut) in result.stderr and "frame 1" in result.stderr and "truncated" in result.stderr
