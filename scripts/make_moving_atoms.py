#!/usr/bin/env python3
"""Writes about a million moving atoms as an MD run, for the playback benchmark (issue 42).

    scripts/make_moving_atoms.py OUT_FOLDER [--copies 16] [--frames 30] [--pdb ../shared/data/1aon.pdb.gz]

Copies of a structure (default GroEL–GroES, 1AON, 58,870 atoms: 16 copies are 941,920 atoms) are laid
on a grid; the run moves every atom in every frame as a thermalised molecule does between saved MD
frames: each copy turns and drifts slowly as a rigid body, and each atom jitters about its place
(a Gaussian of 0.35 Å per axis, drawn anew per frame and seeded, so that two runs write the same
files). Writes OUT_FOLDER/moving.gro (the topology) and OUT_FOLDER/moving.dcd (the frames) with
MDAnalysis, the oracle the tests read trajectories against.
"""
import argparse
import os
import sys
import warnings

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def rotation_z(angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("--pdb", default=os.path.join(ROOT, "..", "shared", "data", "1aon.pdb.gz"))
    ap.add_argument("--copies", type=int, default=16)
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--jitter", type=float, default=0.35, help="Å per axis, per frame")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    import MDAnalysis as mda

    one = mda.Universe(args.pdb)
    centre = one.atoms.positions.mean(axis=0)
    extent = np.ptp(one.atoms.positions, axis=0).max() * 1.05
    side = int(np.ceil(np.sqrt(args.copies)))
    offsets = [np.array([(i % side) * extent, (i // side) * extent, 0.0]) for i in range(args.copies)]
    merged = mda.Merge(*([one.atoms] * args.copies))
    base = np.concatenate([one.atoms.positions - centre for _ in range(args.copies)]).astype(np.float64)
    n = len(one.atoms)
    os.makedirs(args.out, exist_ok=True)
    rng = np.random.default_rng(42)

    def frame(t):
        pos = np.empty_like(base)
        for c, off in enumerate(offsets):
            turn = rotation_z(0.004 * t * (1 if c % 2 == 0 else -1))
            drift = np.array([0.1 * t * np.sin(c), 0.1 * t * np.cos(c), 0.0])
            pos[c * n:(c + 1) * n] = base[c * n:(c + 1) * n] @ turn.T + off + drift
        return (pos + rng.normal(0.0, args.jitter, pos.shape)).astype(np.float32)

    merged.atoms.positions = frame(0)
    merged.dimensions = None
    merged.atoms.write(os.path.join(args.out, "moving.gro"))
    with mda.Writer(os.path.join(args.out, "moving.dcd"), n_atoms=len(merged.atoms)) as w:
        for t in range(args.frames):
            merged.atoms.positions = frame(t)
            w.write(merged.atoms)
    print(f"{len(merged.atoms)} atoms, {args.frames} frames in {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
