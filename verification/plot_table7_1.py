#!/usr/bin/python3
"""Figs. 7.6 and 7.7 of Cook (1989) from a sweep file of inputs/sweep_two_clearance.nml.

    /usr/bin/python3 verification/plot_table7_1.py SWEEP.h5 [--out-prefix verification/fig7]

Fig. 7.6: mean peak-to-peak transmission error of both meshes against mesh frequency,
runs with loss of contact (impacts > 0) filled, Cook's intermittent-contact range
(about 335-480 teeth/s) shaded. Fig. 7.7: maximum, minimum and range of the torque on
shaft element 3 against mesh frequency, with the nominal 798.8 lb-in. Runs that did not
settle within their budget (runs/settled = 0, D-44) are ringed in orange in both.
"""
import argparse

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("file")
    ap.add_argument("--out-prefix", default="fig7")
    ap.add_argument("--title", default="")
    a = ap.parse_args()
    with h5py.File(a.file, "r") as f:
        x = f["parameters/values"][:, 0]
        ids = [s.decode() for s in f["elements/ids"][:]]
        el = {k: f["elements/" + k][:] for k in ("p2p_mean", "impacts", "torque_min", "torque_max")}
        unsettled = (f["runs/settled"][:] == 0) if "settled" in f["runs"] else (x != x)
    fig, ax = plt.subplots(figsize=(8, 5))
    ax.axvspan(335, 480, color="0.88", zorder=0, label="Cook: intermittent contact, about 335-480 teeth/s")
    for name, mark in (("mesh1", "o"), ("mesh2", "s")):
        k = ids.index(name)
        y = el["p2p_mean"][:, k] * 1e3
        lost = el["impacts"][:, k] > 0
        line, = ax.plot(x, y, "-", lw=1.2, label=f"{name} (filled: contact lost)")
        c = line.get_color()
        ax.plot(x[~lost], y[~lost], mark, mfc="white", mec=c, ms=5)
        ax.plot(x[lost], y[lost], mark, mfc=c, mec=c, ms=5)
        if unsettled.any():
            ax.plot(x[unsettled], y[unsettled], "o", mfc="none", mec="tab:orange", mew=1.6, ms=11,
                    label=f"not settled within the budget ({unsettled.sum()} runs): a transient" if name == "mesh1"
                    else "_")
    ax.set_xlabel("mesh frequency (teeth/s)")
    ax.set_ylabel("mean peak-to-peak TE (1e-3 in)")
    ax.set_title("Fig. 7.6: peak-to-peak transmission error vs mesh frequency" + a.title, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(a.out_prefix + "_6.png", dpi=100)
    k = ids.index("shaft3")
    tmin, tmax = el["torque_min"][:, k], el["torque_max"][:, k]
    fig, ax = plt.subplots(figsize=(8, 5))
    ax.plot(x, tmax, "^-", label="maximum")
    ax.plot(x, tmin, "v-", label="minimum")
    ax.plot(x, tmax - tmin, "o-", label="range")
    if unsettled.any():
        for yv, lbl in ((tmax, f"not settled within the budget ({unsettled.sum()} runs): a transient"),
                        (tmin, "_"), (tmax - tmin, "_")):
            ax.plot(x[unsettled], yv[unsettled], "o", mfc="none", mec="tab:orange", mew=1.6, ms=11, label=lbl)
    ax.axhline(798.8, color="k", ls="--", lw=1, label="nominal 798.8 lb-in")
    ax.set_xlabel("mesh frequency (teeth/s)")
    ax.set_ylabel("torque on shaft EL3 (lb-in)")
    ax.set_title("Fig. 7.7: torque on shaft EL3 vs mesh frequency" + a.title, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(a.out_prefix + "_7.png", dpi=100)
    print(a.out_prefix + "_6.png", a.out_prefix + "_7.png")


if __name__ == "__main__":
    main()
