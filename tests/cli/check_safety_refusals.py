"""Issue 20 items 3 and 11 (D-55, D-56): the reproducers of tests/decks/safety end as
they must, quickly, with a message that names the part to blame:
  - smith_law_creep.nml (rk4, dt 8e-6, a Smith-law mesh closed at the floor
    velocity under 798.8 lb-in): exit 2 before the first step, naming element
    'mesh', its deck line and a dt below RK4's real-axis limit 2.785 m_eff/(c D p)
    = 3.05e-7 s (hand value from the deck: D = phi(e) k / V, p = F/k, F = 798.8/3.7588);
  - arkode_explicit_stiff_contact.nml (contact damping 2e8 under arkode-dp): exit 1
    before the first step naming element 'coupling' and cvode-bdf (it never ended);
  - overdamped_node.nml (node damping 2^31 under rk4): exit 2 naming node 'shaft',
    'damping' and its deck line; no warning that "the run goes on";
  - event_flood_segv.nml with mesh.mesh_frequency=1e19: exit 1 "event flood" naming
    element 'mesh' (it was a SIGSEGV / Debug index error), nothing left behind.
Each within BUDGET seconds (a Debug build on a loaded 2-core machine included).
Usage: check_safety_refusals.py TRAINSIM"""
import os, re, shutil, subprocess, sys, tempfile, time

exe = os.path.abspath(sys.argv[1])
here = os.path.dirname(os.path.abspath(__file__))
decks = os.path.normpath(os.path.join(here, "..", "decks", "safety"))
BUDGET = 60.0
failed = 0


def run(deck, extra=(), files=()):
    with tempfile.TemporaryDirectory() as tmp:
        shutil.copy(os.path.join(decks, deck), os.path.join(tmp, "deck.nml"))
        for f in files:
            shutil.copy(os.path.join(decks, f), tmp)
        t0 = time.time()
        try:
            r = subprocess.run([exe, "run", "deck.nml", "-o", "out.h5", *extra], cwd=tmp, capture_output=True,
                               text=True, timeout=BUDGET)
            rc, err = r.returncode, r.stderr
        except subprocess.TimeoutExpired:
            rc, err = None, "timeout"
        left = sorted(set(os.listdir(tmp)) - {"deck.nml", *files})
        return rc, err, time.time() - t0, left


def check(name, cond, detail):
    global failed
    print(f"{'ok  ' if cond else 'FAIL'} {name}: {detail[:400]}")
    failed += 0 if cond else 1


# Smith law: the hand value of the limit (D-55), from the deck's numbers
k, rb, j, v = 234500.0, 3.7588, 0.987, 1.0e-3
e = (1.0 - 2.718281828459045 ** (-0.0263 * v)) / 3.0              # eq. (3.20)
phi = 6.0 * (1.0 - e) / ((2.0 * e - 1.0) ** 2 + 3.0)              # eq. (3.12): D V / k
c_d = phi * (798.8 / rb) / v                                       # c D p at p = F/k
m_eff = 1.0 / (2.0 * rb ** 2 / j)
lam = c_d / m_eff
lam = 0.5 * (lam + (lam ** 2 - 4.0 * 1.8 * k / m_eff) ** 0.5)      # the fast real root (two-pair stiffness)
h_hand = 2.785293 / lam                                            # RK4's radius on the negative real axis
rc, err, dt, left = run("smith_law_creep.nml")
m = re.search(r"take dt below (\S+) s", err)
h_msg = float(m.group(1)) if m else float("nan")
check("smith_law_creep refused", rc == 2 and "element 'mesh' (deck.nml:" in err and abs(h_msg / h_hand - 1.0) < 1e-2
      and not left,
      f"exit {rc} in {dt:.2f} s, limit {h_msg:.4g} s against {h_hand:.4g} s by hand; {err.strip()[-300:]}")

rc, err, dt, left = run("arkode_explicit_stiff_contact.nml", files=("wind_load.txt",))
check("arkode explicit stiff contact refused", rc == 1 and "element 'coupling'" in err and "cvode-bdf" in err
      and dt < BUDGET and not left, f"exit {rc} in {dt:.2f} s; {err.strip()[-300:]}")

rc, err, dt, left = run("overdamped_node.nml")
lines = [l for l in err.splitlines() if l.startswith("trainsim:")]
check("overdamped node refused", rc == 2 and "node 'shaft'" in err and "damping" in err and "deck.nml:4" in err
      and "run goes on" not in err and "0.000 Hz" not in err and len(lines) == 1 and not left,
      f"exit {rc} in {dt:.2f} s; {err.strip()[-300:]}")

rc, err, dt, left = run("event_flood_segv.nml", extra=("--set", "mesh.mesh_frequency=1e19"))
check("event flood message", rc == 1 and "event flood" in err and "element 'mesh'" in err and not left
      and "Backtrace" not in err and dt < BUDGET, f"exit {rc} in {dt:.2f} s, left {left}; {err.strip()[-300:]}")

print(f"{4 - failed} passed, {failed} failed")
sys.exit(1 if failed else 0)
