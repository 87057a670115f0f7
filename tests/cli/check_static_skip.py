#!/usr/bin/python3
"""A gear mesh whose static reference is not computed says so (D-138); a large train
gets it (D-152).

    /usr/bin/python3 tests/cli/check_static_skip.py <trainsim>

The quasi-static reference (D-103, D-118) was skipped above 400 nodes while its Newton
solve was dense; its solve is banded now (D-152) and has no size limit. It is still
skipped when the static preload refuses the train (an element with more than two
ports): Kv, the static force and the static TE are then 0. The check: a held driver,
a spur mesh and a chain of shafts behind the driven gear, loaded at its far end,
  - 400 and 1 000 nodes: the static force computed, equal to the closed form T / r_b2
    (a statically determinate chain: the mesh carries the load torque over the driven
    gear's base radius, whatever the shafts' stiffness), no warning, no `kv_absent`
    attribute;
and a planetary stage (a 3-port carrier) with a spur mesh: the warning names the
element with more than two ports.
"""
import os
import tempfile

import h5py

from clicheck import check, run, finish


def chain_deck(n_nodes):
    """Driver 'a' held at 1 rad/s, mesh to 'b', then n_nodes - 2 shafts in a chain."""
    lines = ["&run t_end = 2e-4, dt = 1e-6, integrator = 'rk4', output_interval = 1e-5 /",
             "&node id = 'a', type = 'inertia', inertia = 1.0 /",
             "&node id = 'b', type = 'inertia', inertia = 1.0 /",
             "&element id = 'mesh', type = 'spur_gear', left = 'a', right = 'b', stiffness = 1e6, rb_driver = 1.0, "
             "rb_driven = 2.0, teeth = 20, contact_ratio = 1.6, approach_angle = 0.0, half_backlash = 0.01 /"]
    prev = 'b'
    for i in range(1, n_nodes - 1):
        lines.append(f"&node id = 's{i}', type = 'inertia', inertia = 1.0 /")
        lines.append(f"&element type = 'shaft', left = '{prev}', right = 's{i}', stiffness = 1e5 /")
        prev = f's{i}'
    lines += ["&load node = 'a', kind = 'constant', quantity = 'speed', value = 1.0 /",
              f"&load node = '{prev}', value = -200.0 /",
              "&initial node = 'a', speed = 1.0 /"]
    return "\n".join(lines) + "\n"


def run_deck(tmp, name, text):
    deck = os.path.join(tmp, name + ".nml")
    out = os.path.join(tmp, name + ".h5")
    with open(deck, "w") as f:
        f.write(text)
    r = run(["run", deck, "-o", out])
    attrs, kv = {}, None
    if os.path.exists(out):
        with h5py.File(out, "r") as f:
            attrs = dict(f.attrs)
            kv = (f["metrics/static_force"][:].ravel()[0], f["metrics/kv"][:].ravel()[0])
    return r, attrs, kv


def attr_text(attrs, key):
    v = attrs.get(key)
    return v.decode() if isinstance(v, bytes) else v


def main():
    with tempfile.TemporaryDirectory() as tmp:
        for n in (400, 1000):
            r, attrs, kv = run_deck(tmp, f"n{n}", chain_deck(n))
            check(f"{n} nodes: run exits 0", r.returncode == 0, r.stderr)
            # T / r_b2 = 200 / 2; the Newton solve stops at 1e-11 of the torque scale
            check("... the mesh's static force computed (T / r_b2 = 100)",
                  kv is not None and abs(kv[0] - 100.0) < 1e-9 * 200.0, str(kv))
            check("... no warning in the print-out", "warning: no dynamic factor Kv" not in r.stdout, r.stdout[-400:])
            check("... no kv_absent attribute", "kv_absent" not in attrs, str(attrs.get("kv_absent")))

        deck = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "inputs",
                            "planetary_start_stop.nml")
        with open(deck) as f:
            text = f.read().replace("t_end = 1.2", "t_end = 2e-4")
        check("the planetary deck (its carrier has more than two ports) is as this check expects",
              "&planetary" in text and "t_end = 2e-4" in text)
        r, attrs, kv = run_deck(tmp, "planet", text)
        warn = [ln for ln in r.stdout.splitlines() if ln.startswith("warning: no dynamic factor Kv")]
        check("planetary stage: the print-out warns and names the element with more than two ports",
              r.returncode == 0 and len(warn) == 1 and "more than two ports" in warn[0],
              f"rc {r.returncode}: {r.stdout[-600:]} {r.stderr[-300:]}")
        why = attr_text(attrs, "kv_absent")
        check("... kv_absent in the file says the same", why is not None and "more than two ports" in why, str(why))
    finish()


if __name__ == "__main__":
    main()
