"""An MD trajectory through MDAnalysis: the protein and the water near it, frame by frame, with a still
camera (docs/python.md, "Trajectories").

    PYTHONPATH=build/release/python /usr/bin/python3 examples/python/md_trajectory.py ../shared/data/md_1tii_chainD.gro ../shared/data/md_1tii_chainD.xtc
"""
import sys

import MDAnalysis as mda

import penumbra


def main(topology: str, trajectory: str) -> None:
    u = mda.Universe(topology, trajectory)
    protein = u.select_atoms("protein")
    shell = u.select_atoms("resname SOL and around 3.5 protein", updating=True)
    scene = penumbra.Scene({"shadows": {"technique": "issm"}, "ambient": {"technique": "particle_ao"}})
    scene.add_atoms(protein)
    scene.add_atoms(shell, radius_scale=0.6)
    r = penumbra.Renderer(scene)
    for ts in u.trajectory[::50]:
        r.set_frame(ts)
        frame = r.render(width=320, height=240)
        spheres = [p["spheres"] for p in r.stats["particles"]]
        print(f"frame {ts.frame}: {spheres} spheres, {frame.shape[1]}x{frame.shape[0]}, {r.stats['timings_ms']['total']:.0f} ms")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
