#!/usr/bin/env python3
"""Error against frame time, per scene: the techniques of one `penumbra bench` run on one chart.

    scripts/bench_charts.py BENCH_DIR [--out DIR] [--format png|svg]

Reads BENCH_DIR/bench.json (written by `penumbra bench`) and draws, for every scene of every suite
that measured both, each technique as a point: x the frame time with its structures cached (ms, log
scale), y its PSNR against the suite's exact reference (dB; higher is better), the point's area
proportional to the memory its illumination holds (maps, caches, tables). The exact reference is drawn
at the top edge at its own time, so a user sees what the approximation buys. Points whose reference
differs (ambient occlusion is measured against the sampled or ray-traced AO, shadows against ray-traced
shadows) say so in their label. Writes chart_<suite>_<scene>.png (or .svg) and charts.md (the
Markdown that shows them) into --out (default BENCH_DIR).

Needs matplotlib (Debian python3-matplotlib); without it, says so and exits 0: charts are optional.
"""
import argparse
import json
import math
import os
import sys

MIB = 1048576.0


def finite(v):
    return isinstance(v, (int, float)) and math.isfinite(v)


def point(label, ms, psnr, memory_bytes, reference=None):
    return {"label": label, "ms": ms, "psnr": psnr, "mib": (memory_bytes or 0) / MIB, "reference": reference}


def cssm_scenes(bench):
    for scene, d in (bench.get("datasets") or {}).items():
        pts = [point(f"{r['technique']} {r['resolution']}²", r["render_ms"], r["psnr"], r["memory_bytes"])
               for r in d.get("runs", [])]
        yield "cssm", scene, pts, ("ray_traced", d.get("ray_traced_ms"))


def dsm_scenes(bench):
    for scene, d in ((bench.get("dsm") or {}).get("datasets") or {}).items():
        pts = []
        if "none" in d:
            pts.append(point("no shadows", d["none"]["render_ms"], d["none"]["psnr"], 0))
        for r in d.get("runs", []):
            pts.append(point(f"{r['label']} {r['resolution']}² ({r['setting']})", r["render_ms"], r["psnr"],
                             r["memory_bytes"]))
        yield "dsm", scene, pts, ("ray_traced", d.get("reference_ms"))


def extinction_scenes(bench):
    for scene, f in ((bench.get("extinction") or {}).get("frames") or {}).items():
        mem = f.get("memory_bytes", {})
        psnr = f.get("psnr", {})
        pts = [point("no illumination", f["plain_ms"], psnr.get("plain_vs_ray"), 0, "ray_traced"),
               point("sat_cone", f["shadows_ms"], psnr.get("cone_vs_ray"), mem.get("shadows"), "ray_traced"),
               point("sat_shells AO", f["ao_ms"], psnr.get("ao_vs_sampled"), mem.get("ao"), "sampled_ao"),
               point("sat_cone + sat_shells", f["lit_ms"], psnr.get("lit_vs_reference"), mem.get("lit"),
                     "ray_traced + sampled_ao")]
        yield "extinction", scene, pts, ("ray_traced + sampled_ao", f.get("reference_ms"))


def particle_scenes(bench):
    for scene, d in ((bench.get("particles") or {}).get("datasets") or {}).items():
        configs, error = d.get("configs", {}), d.get("error")
        if not error:
            continue  # the largest sets are not compared with the reference
        def psnr(key):
            v = (error.get(key) or {}).get("psnr")
            return float("inf") if v == "inf" else v
        pts = []
        for name, label, key, ref in (("ll", "local lighting", "ll_vs_ray_traced", "ray_traced"),
                                      ("issm", "issm", "issm_vs_ray_traced", "ray_traced"),
                                      ("issm_ao", "issm + particle_ao", "issm_ao_vs_ray_traced_ao",
                                       "ray_traced + ray_traced_ao")):
            c = configs.get(name)
            if c:
                pts.append(point(label, c["cached_ms"], psnr(key), c.get("shadow_bytes", 0) + c.get("ambient_bytes", 0),
                                 ref))
        yield "particles", scene, pts, None


def all_scenes(bench):
    for source in (cssm_scenes, dsm_scenes, extinction_scenes, particle_scenes):
        yield from source(bench)


def draw(matplotlib, plt, suite, scene, pts, reference, path):
    pts = [p for p in pts if finite(p["ms"]) and isinstance(p["psnr"], (int, float)) and not math.isnan(p["psnr"])]
    if not pts:
        return False
    # an image equal to the reference (PSNR ∞) sits on the reference's line, above every finite point
    finite_psnr = [p["psnr"] for p in pts if math.isfinite(p["psnr"])]
    exact_y = (max(finite_psnr) if finite_psnr else 40.0) + 4
    fig, ax = plt.subplots(figsize=(7.5, 4.8), dpi=110)
    largest = max(p["mib"] for p in pts) or 1.0
    for i, p in enumerate(pts):
        area = 30 + 900 * p["mib"] / largest
        y = p["psnr"] if math.isfinite(p["psnr"]) else exact_y
        ax.scatter([p["ms"]], [y], s=area, alpha=0.55, color=plt.cm.tab20(i % 20), edgecolors="black",
                   linewidths=0.6, label=f"{p['label']}: {p['ms']:.3g} ms, {p['psnr']:.1f} dB, {p['mib']:.1f} MiB"
                         + (f" (vs {p['reference']})" if p["reference"] else ""))
    times = [p["ms"] for p in pts]
    if reference and finite(reference[1]):
        ax.scatter([reference[1]], [exact_y], marker="*", s=160, color="black",
                   label=f"exact reference ({reference[0]}): {reference[1]:.3g} ms")
        times.append(reference[1])
    ax.axhline(exact_y, color="black", linewidth=0.5, linestyle=":")
    if max(times) / max(min(times), 1e-9) > 5:  # a log axis where the times spread far
        ax.set_xscale("log")
        ax.xaxis.set_major_locator(matplotlib.ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
        ax.xaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}"))
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.set_xlabel("frame time with cached structures, ms")
    ax.set_ylabel("PSNR against the exact reference, dB (dotted: exact)")
    ax.set_title(f"{suite}: {scene} — area ∝ memory (largest {largest:.1f} MiB)")
    ax.grid(True, which="both", alpha=0.3)
    legend = ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    for handle in legend.legend_handles if hasattr(legend, "legend_handles") else legend.legendHandles:
        handle.set_sizes([40])  # the legend names the points; their areas are on the chart
    fig.savefig(path, bbox_inches="tight")
    plt.close(fig)
    return True


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("bench_dir")
    ap.add_argument("--out")
    ap.add_argument("--format", choices=("png", "svg"), default="png")
    args = ap.parse_args()
    source = os.path.join(args.bench_dir, "bench.json")
    try:
        with open(source) as f:
            bench = json.load(f)
    except (OSError, ValueError) as e:
        sys.exit(f"bench_charts: cannot read {source}: {e}")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        import matplotlib.ticker  # noqa: F401 (the axis formatters)
    except ImportError:
        print("bench_charts: matplotlib not installed (Debian python3-matplotlib): no charts drawn")
        return 0
    out = args.out or args.bench_dir
    os.makedirs(out, exist_ok=True)
    lines = []
    for suite, scene, pts, reference in all_scenes(bench):
        name = f"chart_{suite}_{scene}.{args.format}"
        if draw(matplotlib, plt, suite, scene, pts, reference, os.path.join(out, name)):
            lines.append(f"![{suite}: {scene}, error against frame time]({name})")
            print(f"bench_charts: {os.path.join(out, name)}")
    with open(os.path.join(out, "charts.md"), "w") as f:
        f.write("\n\n".join(lines) + ("\n" if lines else ""))
    if not lines:
        print("bench_charts: no suite in this run measured both time and error")
    return 0


if __name__ == "__main__":
    sys.exit(main())
