#!/usr/bin/python3
"""`trainsim planetary` (issue 25 item 3) against the Willis equation, and its refusals.

Usage (as CTest runs it, cwd = repo root):

    /usr/bin/python3 tests/cli/check_planetary_calc.py <path to trainsim>

(a) For several stages, each printed ratio put into the Willis equation
    (w_s - w_c)/(w_r - w_c) = -z_r/z_s with the held member at rest and the output at 1
    (exact fractions here; the printed value is the shortest round-trip decimal, so the
    residual is a few units of roundoff: 1e-14 relative), and each planet speed on the
    carrier against w_p - w_c = -(z_s/z_p)(w_s - w_c) of that motion.
(b) The mesh phases printed for each planet against -z psi/360 mod 1 (psi = 360 (n-1)/N),
    and sun + ring phases a whole number of teeth (the stage assembles).
(c) The deck fragment, its placeholders filled, is a deck `trainsim modes` builds; its
    rigid-body mode (ring held) turns the carrier at 1/ratio of the sun (6 printed decimals).
(d) Tooth counts that cannot assemble, a ring that is not z_s + 2 z_p, no planets, an
    unknown option: exit 2 with a message naming the option and value.
"""
import os
import re
import subprocess
import sys
import tempfile
from fractions import Fraction

EXE = sys.argv[1]
failures = []


def check(ok, text):
    print(("ok   " if ok else "FAIL ") + text)
    if not ok:
        failures.append(text)


def calc(*args):
    p = subprocess.run([EXE, "planetary", *map(str, args)], capture_output=True, text=True, timeout=60)
    return p.returncode, p.stdout, p.stderr


def close(a, b, rel=1e-14):
    return abs(a - b) <= rel * max(abs(b), 1e-300)


STAGES = [(21, 30, 3), (36, 24, 5), (36, 24, 4), (24, 18, 2), (20, 22, 4)]
for zs, zp, n in STAGES:
    zr = zs + 2 * zp
    code, out, err = calc("--teeth-sun", zs, "--teeth-planet", zp, "--planets", n, "--module", 2)
    check(code == 0, f"{zs}/{zp}/{zr}, N={n}: exit 0 ({err.strip()})")
    if code:
        continue
    ratio = {m: float(re.search(m + r"\s+ratio (\S+)", out).group(1))
             for m in ("ring held:    sun -> carrier ", "sun held:     ring -> carrier", "carrier held: sun -> ring    ")}
    r_ring, r_sun, r_carrier = ratio.values()
    willis = -Fraction(zr, zs)
    # ring held: w_r = 0, w_c = 1, w_s = ratio
    check(close((r_ring - 1) / (0 - 1), float(willis)), f"{zs}/{zp}/{zr}: ring held, Willis ({r_ring})")
    # sun held: w_s = 0, w_c = 1, w_r = ratio
    check(close((0 - 1) / (r_sun - 1), float(willis)), f"{zs}/{zp}/{zr}: sun held, Willis ({r_sun})")
    # carrier held: w_c = 0, w_r = 1, w_s = ratio
    check(close(r_carrier / 1, float(willis)), f"{zs}/{zp}/{zr}: carrier held, Willis ({r_carrier})")
    # planet on the carrier per unit input speed
    m = re.search(r"ring held (\S+), sun held (\S+), carrier held (\S+)", out)
    pl = [float(x) for x in m.groups()]
    k = -Fraction(zs, zp)
    check(close(pl[0], float(k * (1 - 1 / Fraction(1 + Fraction(zr, zs))))), f"{zs}/{zp}/{zr}: planet, ring held")
    check(close(pl[1], float(k * (0 - 1 / Fraction(1 + Fraction(zs, zr))))), f"{zs}/{zp}/{zr}: planet, sun held")
    check(close(pl[2], float(k)), f"{zs}/{zp}/{zr}: planet, carrier held")
    # (b) phases
    rows = re.findall(r"^\s+(\d+)\s+(\S+)\s+(\S+)\s+(\S+)$", out, re.M)
    check(len(rows) == n, f"{zs}/{zp}/{zr}: {n} phase rows")
    for i, psi, ps, pr in rows:
        i = int(i)
        es = Fraction(-zs * (i - 1), n) % 1
        er = Fraction(-zr * (i - 1), n) % 1
        check(abs(float(ps) - float(es)) < 1e-12 and abs(float(pr) - float(er)) < 1e-12
              and (es + er) % 1 == 0, f"{zs}/{zp}/{zr}: planet {i} phases {ps}, {pr}")
    # (c) the fragment
    frag = out[out.index("&planetary"):]
    frag = (frag.replace("face_width = F", "face_width = 0.5").replace("= B", "= 0.0")
            .replace("JS", "0.01").replace("JC", "0.2").replace("JP", "0.003"))
    with tempfile.TemporaryDirectory() as d:
        deck = os.path.join(d, "deck.nml")
        with open(deck, "w") as f:
            f.write("&run t_end = 0.01, dt = 1e-6 /\n" + frag)
        p = subprocess.run([EXE, "modes", deck, "--closed"], capture_output=True, text=True, timeout=60)
        check(p.returncode == 0, f"{zs}/{zp}/{zr}: the fragment builds ({p.stderr.strip()[:200]})")
        if p.returncode:
            continue
        mode1 = p.stdout.split("mode  2:")[0]
        sun = float(re.search(r"ps_sun\s+(\S+)", mode1).group(1))
        car = float(re.search(r"ps_carrier\s+(\S+)", mode1).group(1))
        check(abs(car / sun - 1 / r_ring) < 1e-6, f"{zs}/{zp}/{zr}: rigid mode carrier/sun {car / sun} = 1/{r_ring}")

# (d) refusals
for args, words in [
    (("--teeth-sun", 21, "--teeth-planet", 30, "--planets", 4), ["(21 + 81)/4", "cannot be assembled", "1, 2, 3, 6, 17"]),
    (("--teeth-sun", 21, "--teeth-planet", 30, "--teeth-ring", 78, "--planets", 3), ["--teeth-ring", "= 81", "got 78"]),
    (("--teeth-sun", 21, "--teeth-planet", 30, "--planets", 0), ["--planets", "got 0"]),
    (("--teeth-sun", 21.5, "--teeth-planet", 30, "--planets", 3), ["--teeth-sun", "whole number", "21.5"]),
    (("--teeth-sun", 21, "--teeth-planet", 30, "--planet", 3), ["unknown option '--planet'", "--planets N"]),
]:
    code, out, err = calc(*args)
    check(code == 2 and all(w in err for w in words) and "Backtrace" not in err,
          f"refused {' '.join(map(str, args))}: exit {code}, {err.strip()[:160]}")
# a crowded stage: a warning, not a refusal
code, out, err = calc("--teeth-sun", 12, "--teeth-planet", 40, "--planets", 4)
check(code == 0 and "do not fit" in err, f"crowded planets warned ({err.strip()[:120]})")

print(f"{'FAILED' if failures else 'passed'}: {len(failures)} failure(s)")
sys.exit(1 if failures else 0)
