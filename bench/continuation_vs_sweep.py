#!/usr/bin/env python3
"""The cost of the Fig. 5.11 frequency response by continuation against the settled
brute-force sweep, as a ratio measured in one run (docs/benchmarks.md "Continuation").

Runs verification/continuation/study.py over the whole range (645 -> 385 teeth/s, the
sweep's 27 runs settled to 1e-8) for each shaft damping given (default 500 and 50 lb in
s/rad: the bundled rig is undamped and no brute-force run settles to its marginal
orbits), and prints CPU seconds of each and sweep / continuation.

Usage: continuation_vs_sweep.py TRAINSIM [--damping D ...] [--case fig5_11|table7_1]
"""
import argparse
import contextlib
import io
import os
import re
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                                "verification", "continuation"))
import study  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("trainsim")
    ap.add_argument("--damping", type=float, nargs="+", default=[500.0, 50.0])
    ap.add_argument("--case", default="fig5_11")
    a = ap.parse_args()
    print(f"{'damping':>8} {'continue CPU s':>15} {'sweep CPU s':>12} {'sweep/continue':>15} {'largest diff':>13}")
    for d in a.damping:
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            study.main([a.trainsim, "--case", a.case, "--damping", str(d)])
        text = buf.getvalue()
        c = float(re.search(r"continuation: .*CPU ([0-9.]+) s", text).group(1))
        s = float(re.search(r"sweep: .*CPU ([0-9.]+) s", text).group(1))
        w = re.search(r"largest relative difference sweep - branch: (\S+)", text).group(1)
        print(f"{d:8g} {c:15.2f} {s:12.2f} {s / c:15.2f} {w:>13}")


if __name__ == "__main__":
    main()
