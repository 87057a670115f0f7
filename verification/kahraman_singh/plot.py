#!/usr/bin/python3
"""Frequency response of the Kahraman-Singh-type case: amplitude of the dynamic TE against
Omega, up- and down-sweep, the regime of each point marked; the reference (lines, filled
markers) and, with --h5, trainsim's sweep (open markers).

    plot.py REF.json [--h5 SWEEP.h5] [--out ks_frequency_response.png]
"""
import argparse
import json
import os
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

COLOR = {"no_impact": "tab:green", "single_sided": "tab:orange", "double_sided": "tab:red",
         "undetermined": "tab:gray"}
LABEL = {"no_impact": "no impact", "single_sided": "single-sided impacts", "double_sided": "double-sided impacts"}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("ref")
    ap.add_argument("--h5")
    ap.add_argument("--out", default=os.path.join(HERE, "ks_frequency_response.png"))
    a = ap.parse_args()
    rf = json.load(open(a.ref))
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(8, 8), dpi=110, sharex=True,
                                  gridspec_kw={"height_ratios": [3, 2]})
    for br, mk, ls in (("up", ">", "-"), ("down", "<", "--")):
        pts = rf[br]
        om = [p["omega"] for p in pts]
        for axis, key in ((ax, "x_amp"), (ax2, "q_min")):
            val = [p[key] for p in pts]
            axis.plot(om, val, ls, color="0.4", lw=1, label="reference, %s-sweep" % br)
            for reg in COLOR:
                sel = [(o, y) for o, y, p in zip(om, val, pts) if p["regime"] == reg]
                if sel:
                    axis.plot([s[0] for s in sel], [s[1] for s in sel], mk, color=COLOR[reg], ms=6, ls="none")
    ax2.axhline(1.0, color="k", lw=0.8)
    ax2.axhline(-1.0, color="k", lw=0.8)
    ax2.text(0.995, 1.02, "front face: q < 1 separates", transform=ax2.get_yaxis_transform(), ha="right",
             va="bottom", fontsize=8)
    ax2.text(0.995, -0.98, "rear face: q < -1 contacts", transform=ax2.get_yaxis_transform(), ha="right",
             va="bottom", fontsize=8)
    ax2.set_ylabel("q_min = min (delta - e)/b (reference)")
    ax2.grid(alpha=0.3)
    if a.h5:
        import compare
        ts = compare.read_sweep(a.h5, sum(abs(x) for x in rf["params"]["e"]))
        for br, mk in (("up", ">"), ("down", "<")):
            for p in ts[br]:
                ax.plot(p["omega"], p["x_amp"], mk, mfc="none", mec="k", ms=10, ls="none")
        ax.plot([], [], "o", mfc="none", mec="k", ms=10, ls="none", label="trainsim sweep (open markers)")
    for reg in ("no_impact", "single_sided", "double_sided"):
        ax.plot([], [], "s", color=COLOR[reg], ls="none", label=LABEL[reg])
    p = rf["params"]
    ax.set_title("Kahraman-Singh-type mesh: zeta=%g, F_m=%g, a=%s, e=%s" % (p["zeta"], p["F_m"], p["a"], p["e"]),
                 fontsize=9)
    ax2.set_xlabel("Omega = mesh frequency / natural frequency")
    ax.set_ylabel("x_amp = (max - min)/2 of delta / b")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    fig.savefig(a.out)
    print("wrote", a.out)


if __name__ == "__main__":
    main()
