#!/usr/bin/env python3
"""Selection evaluation time on about a million atoms, for docs/BENCHMARKS.md.

usage: scripts/bench_selection.py PENUMBRA [COPIES_PER_AXIS]

The staged GROMACS frame (../shared/data/md_1tii_chainD.gro, 18,182 atoms in a triclinic box) is
replicated COPIES_PER_AXIS³ times (default 4: 64 copies, 1,163,648 atoms) along its own cell vectors
into one periodic system whose box is the copies' box, written as a .gro, and `penumbra select`
evaluates each selection of SELECTIONS on it (the file's coordinates and box: periodic). The table
gives the atoms selected and the evaluation time (parsing and reading excluded), median of 3 runs.
"""
import os, re, statistics, subprocess, sys, tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
GRO = os.path.join(ROOT, "..", "shared", "data", "md_1tii_chainD.gro")
SELECTIONS = ["protein", "name CA and resid 10:100", "resname SOL and not name OW", "byres name NA",
              "around 5 protein", "within 3 of resname NA CL", "sphzone 20 resid 50", "same residue as around 3.5 resname CL"]


def replicated(path, n, out):
    lines = open(path).read().splitlines()
    count = int(lines[1])
    atoms = lines[2:2 + count]
    box = [float(v) for v in lines[2 + count].split()]
    box += [0.0] * (9 - len(box))
    a = (box[0], box[3], box[4])
    b = (box[5], box[1], box[6])
    c = (box[7], box[8], box[2])
    with open(out, "w") as f:
        f.write(f"{n ** 3} copies of {os.path.basename(path)}\n{count * n ** 3}\n")
        serial = 0
        for i in range(n):
            for j in range(n):
                for k in range(n):
                    shift = [i * a[d] + j * b[d] + k * c[d] for d in range(3)]
                    copy = i * n * n + j * n + k
                    for line in atoms:
                        resid = (int(line[0:5]) + copy * 1000) % 100000
                        x, y, z = (float(line[20 + 8 * d:28 + 8 * d]) + shift[d] for d in range(3))
                        serial = serial % 99999 + 1
                        f.write(f"{resid:5d}{line[5:15]}{serial:5d}{x:8.3f}{y:8.3f}{z:8.3f}\n")
        big = [v * n for v in box]
        f.write(" ".join(f"{v:.5f}" for v in big) + "\n")
    return count * n ** 3


def main():
    binary = sys.argv[1]
    n = int(sys.argv[2]) if len(sys.argv) > 2 else 4
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "replicated.gro")
        atoms = replicated(GRO, n, path)
        print(f"{atoms:,} atoms ({n ** 3} copies of md_1tii_chainD.gro, periodic box)\n")
        print("| selection | atoms selected | evaluation median ms (3 runs) |")
        print("|---|---:|---:|")
        for sel in SELECTIONS:
            times, selected = [], None
            for _ in range(3):
                out = subprocess.run([binary, "select", path, sel], check=True, capture_output=True, text=True).stdout
                times.append(float(re.search(r"evaluated\s+([\d.]+) ms", out).group(1)))
                selected = int(re.search(r"selected\s+(\d+)", out).group(1))
            print(f"| `{sel}` | {selected:,} | {statistics.median(times):.1f} |")
            sys.stdout.flush()


if __name__ == "__main__":
    main()
