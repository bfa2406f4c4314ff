"""Atom selections (src/penumbra/data/selection) against MDAnalysis's select_atoms as the oracle.

`penumbra select TOPOLOGY SELECTION [--trajectory T --frame K] --indices OUT` writes the selected atom
indices; MDAnalysis evaluates the same string on the same files (the staged GROMACS run,
../shared/data/md_1tii_chainD.gro + .xtc, PROVENANCE.md "MD trajectory"; its box is triclinic, and
select_atoms is periodic by default). The index sets must be identical; the selections that depend on
positions are compared at several frames. VMD's `water` and `within`, and `none`, which MDAnalysis 2.4
lacks, are compared with the MDAnalysis strings they stand for. Malformed selections must fail with
the character and what was expected.

    PENUMBRA_CLI=build/release/penumbra /usr/bin/python3 -m pytest -q tests/python/test_selection_oracle.py
"""
import os
import subprocess
import warnings

import numpy as np
import pytest

mda = pytest.importorskip("MDAnalysis")

CLI = os.environ.get("PENUMBRA_CLI", "penumbra")
ROOT = os.environ.get("PENUMBRA_ROOT", os.path.join(os.path.dirname(__file__), "..", ".."))
DATA = os.environ.get("PENUMBRA_DATA_DIR", os.path.join(ROOT, "..", "shared", "data"))
GRO = os.path.join(DATA, "md_1tii_chainD.gro")
XTC = os.path.join(DATA, "md_1tii_chainD.xtc")

warnings.filterwarnings("ignore", category=DeprecationWarning)
warnings.filterwarnings("ignore", category=UserWarning)

# Selections that do not depend on positions: keywords, wildcards, ranges, precedence.
STATIC = [
    "all", "protein", "backbone", "nucleic", "resname SOL", "resname NA CL", "resname S*", "name CA", "name C*",
    "name H?1", "name [CN]A", "name [!CHO]*", "type O", "type NA CL", "resid 10", "resid 10:20", "resid 10-20",
    "resid 10 to 20", "resid 3 : 5", "resid 1 5 9 200:210", "resnum 30-40", "index 0:99", "index 5 17 1000",
    "bynum 1:10", "segid SYSTEM", "protein and not backbone", "protein or resname NA", "not protein and not resname SOL",
    "name CA or name CB and resid 1:5", "not name CA and resid 1:5", "(resid 1:5 or resid 100:105) and name N",
    "same residue as name CA and resid 5", "byres name OW and index 2000:2100", "byres (name NA)",
    "same resname as index 1500", "not (protein or resname SOL)",
]
# Selections that depend on positions, compared at every frame of FRAMES.
GEOMETRIC = [
    "around 5 protein", "around 3.5 resname NA CL", "sphzone 10 protein", "sphzone 6 resid 10",
    "resname SOL and around 4 resid 50:60", "byres around 3 protein", "same residue as around 3 resname NA",
    "not around 10 protein and resname SOL", "around 2.5 name OW and resid 100", "around 8 (resname CL and index 18000:18182)",
    "around 4 not resname NA CL",  # more reference atoms than tested ones: the grid bins the references
]
FRAMES = [0, 75, 150]
# penumbra's extensions and the MDAnalysis selection each equals
EXTENSIONS = {
    "water": "resname H2O HH0 OHH HOH OH2 SOL WAT TIP TIP2 TIP3 TIP4",
    "none": "not all",
    "within 5 of protein": "protein or around 5 protein",  # around takes all after it
    "water and within 3.5 of resname NA": "resname SOL and (resname NA or around 3.5 resname NA)",
}


def staged():
    for path in (GRO, XTC):
        if not os.path.exists(path):
            pytest.skip(f"missing data: {path} not found")


@pytest.fixture(scope="module")
def universe():
    staged()
    return mda.Universe(GRO, XTC)


def penumbra_select(selection, tmp_path, frame=None):
    out = tmp_path / "indices.txt"
    args = [CLI, "select", GRO, selection, "--indices", str(out)]
    if frame is not None:
        args += ["--trajectory", XTC, "--frame", str(frame)]
    result = subprocess.run(args, capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    text = out.read_text()
    return np.array([int(v) for v in text.split()], dtype=np.int64)


def mdanalysis_select(u, selection, frame):
    u.trajectory[frame]
    return u.select_atoms(selection).indices


def test_there_are_enough_selections():
    assert len(STATIC) + len(GEOMETRIC) >= 30


@pytest.mark.parametrize("selection", STATIC)
def test_static_selection_matches_mdanalysis(universe, tmp_path, selection):
    ours = penumbra_select(selection, tmp_path)
    np.testing.assert_array_equal(ours, mdanalysis_select(universe, selection, 0), err_msg=selection)


@pytest.mark.parametrize("selection", GEOMETRIC)
def test_geometric_selection_matches_mdanalysis_at_frames(universe, tmp_path, selection):
    for frame in FRAMES:
        ours = penumbra_select(selection, tmp_path, frame)
        theirs = mdanalysis_select(universe, selection, frame)
        assert len(theirs) > 0 or selection.startswith("same residue"), selection
        np.testing.assert_array_equal(ours, theirs, err_msg=f"{selection} at frame {frame}")


def test_geometric_selections_change_between_frames(universe, tmp_path):
    """The frames differ, so a test that compared one frame's answer with itself would be caught."""
    a = penumbra_select("around 5 protein", tmp_path, 0)
    b = penumbra_select("around 5 protein", tmp_path, 150)
    assert not np.array_equal(a, b)


def test_periodic_images_count(universe, tmp_path):
    """Around the protein, the minimum image matters: without the box MDAnalysis finds other atoms."""
    universe.trajectory[150]
    periodic = universe.select_atoms("around 8 resname CL").indices
    plain = universe.select_atoms("around 8 resname CL", periodic=False).indices
    assert not np.array_equal(periodic, plain), "no atom near a periodic image: the check below would prove nothing"
    np.testing.assert_array_equal(penumbra_select("around 8 resname CL", tmp_path, 150), periodic)


@pytest.mark.parametrize("ours,theirs", sorted(EXTENSIONS.items()))
def test_extensions_match_their_mdanalysis_equivalents(universe, tmp_path, ours, theirs):
    for frame in FRAMES:
        np.testing.assert_array_equal(penumbra_select(ours, tmp_path, frame), mdanalysis_select(universe, theirs, frame),
                                      err_msg=ours)


# malformed selections: the message names the character and what was expected; MDAnalysis refuses them too
MALFORMED = [
    ("name", "at character 5: expected a value after 'name', found the end of the selection"),
    ("protein and", "at character 12: expected a selection"),
    ("(protein or name CA", "at character 20: expected ')' closing the '(' at character 1, found the end of the selection"),
    ("resid a:b", "at character 7: expected a number or a range"),
    ("around protein", "at character 8: expected a distance in Å"),
    ("prot", "at character 1: expected a selection keyword"),
    ("protein CA", "at character 9: expected 'and', 'or' or the end of the selection, found 'CA'"),
    ("same foo as protein", "at character 6: expected a property after 'same'"),
    ("index 1-", "at character 7: expected a number or a range"),
]


@pytest.mark.parametrize("selection,message", MALFORMED)
def test_malformed_selection_names_position_and_expectation(universe, selection, message):
    staged()
    result = subprocess.run([CLI, "select", GRO, selection], capture_output=True, text=True)
    assert result.returncode != 0
    assert message in result.stderr, result.stderr
    with pytest.raises(Exception):
        universe.select_atoms(selection)


# A PDB file (gemmi's reading against MDAnalysis's PDB parser): chain ids, segment ids (the chain
# where the file has none), element types, the CRYST1 box (hexagonal: 90/90/120°).
PDB = os.path.join(DATA, "1tii.pdb")
PDB_SELECTIONS = [
    "all", "protein", "chainID A and name CA", "segid D", "resid 10:20 and chainID D", "resname HOH", "type C",
    "type FE S", "name O*", "byres around 4 resname HOH", "around 5 chainID D", "sphzone 10 chainID E", "bynum 5000:5100",
    "same residue as index 100",
]


@pytest.fixture(scope="module")
def pdb_universe():
    if not os.path.exists(PDB):
        pytest.skip(f"missing data: {PDB} not found")
    return mda.Universe(PDB)


@pytest.mark.parametrize("selection", PDB_SELECTIONS)
def test_pdb_selection_matches_mdanalysis(pdb_universe, tmp_path, selection):
    out = tmp_path / "indices.txt"
    result = subprocess.run([CLI, "select", PDB, selection, "--indices", str(out)], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    ours = np.array([int(v) for v in out.read_text().split()], dtype=np.int64)
    np.testing.assert_array_equal(ours, pdb_universe.select_atoms(selection).indices, err_msg=selection)
