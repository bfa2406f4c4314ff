"""The periodic cell a particle file stores, as the viewer's state reports it (particles[i].box), against
MDAnalysis's `dimensions` turned into cell vectors (`triclinic_vectors`) for the same file: a GRO box
line (a rhombic dodecahedron), a PDB CRYST1 (hexagonal) and a frame of an XTC trajectory."""
import os
import pathlib
import warnings

import numpy as np
import pytest

mda = pytest.importorskip("MDAnalysis")
websocket = pytest.importorskip("websocket")

from MDAnalysis.lib.mdamath import triclinic_vectors  # noqa: E402
from test_viewer_protocol import Viewer, receive  # noqa: E402

ROOT = os.environ.get("PENUMBRA_ROOT", os.path.join(os.path.dirname(__file__), "..", ".."))
DATA = os.environ.get("PENUMBRA_DATA_DIR", os.path.join(ROOT, "..", "shared", "data"))


def data(name):
    path = os.path.join(DATA, name)
    if not os.path.exists(path):
        pytest.skip(f"missing data: {path} not found")
    return path


@pytest.mark.parametrize("topology, trajectory, frame", [("md_1tii_chainD.gro", None, 0), ("1tii.pdb", None, 0),
                                                          ("md_1tii_chainD.gro", "md_1tii_chainD.xtc", 7)])
def test_the_cell_is_mdanalysis_triclinic_box(tmp_path, topology, trajectory, frame):
    entry = {"file": data(topology)}
    if trajectory:
        entry["trajectory"] = data(trajectory)
    v = Viewer(pathlib.Path(tmp_path), {"particles": [entry], "camera": {"width": 32, "height": 32}, "time": frame},
               "--data-root", os.path.abspath(DATA))
    try:
        ws = v.connect()
        box = receive(ws, "state")["particles"][0]["box"]
        ws.close()
    finally:
        assert v.close() == 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        u = mda.Universe(data(topology), data(trajectory)) if trajectory else mda.Universe(data(topology))
    u.trajectory[frame]
    expected = triclinic_vectors(u.dimensions)
    assert np.abs(np.array([box["a"], box["b"], box["c"]]) - expected).max() < 1e-4, (box, expected)
    assert box["origin"] == [0, 0, 0]
