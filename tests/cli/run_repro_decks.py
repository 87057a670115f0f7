"""Every reproducer deck in ../shared/repro (beside the repository, as on CI) ends
within seconds with exit 0 (a correct result), 1 (a numerical failure with a message
naming the time and the element or state) or 2 (bad input naming the deck line and
key): never a hang, a backtrace, a signal, or a temporary file left behind.
Exits 77 (skipped) when ../shared/repro is not there."""
import glob, os, shutil, subprocess, sys, tempfile, time

exe = os.path.abspath(sys.argv[1])
here = os.path.dirname(os.path.abspath(__file__))
repro = os.path.normpath(os.path.join(here, "..", "..", "..", "shared", "repro"))
decks = sorted(glob.glob(os.path.join(repro, "*.nml")))
if not decks:
    print(f"skipped: no reproducer decks in {repro}")
    sys.exit(77)
BUDGET = 60.0   # s per deck, generous for the Debug build on a shared 2-core machine
failed = 0
for deck in decks:
    name = os.path.basename(deck)
    with tempfile.TemporaryDirectory() as tmp:
        shutil.copy(deck, os.path.join(tmp, "deck.nml"))
        t0 = time.time()
        try:
            r = subprocess.run([exe, "run", "deck.nml", "-o", "out.h5"], cwd=tmp, capture_output=True,
                               text=True, timeout=BUDGET)
            rc, err = r.returncode, r.stderr
        except subprocess.TimeoutExpired:
            rc, err = None, "timeout"
        dt = time.time() - t0
        left = [f for f in os.listdir(tmp) if f.endswith(".part")]
        msg = [l for l in err.splitlines() if l.startswith("trainsim:") and "warning" not in l]
        ok = rc in (0, 1, 2) and not left and "Backtrace" not in err and "runtime error" not in err.lower()
        if rc in (1, 2):
            ok = ok and bool(msg)
        print(f"  {'ok  ' if ok else 'FAIL'} {name}: exit {rc} in {dt:.2f} s {msg[0][:150] if msg else ''}")
        failed += 0 if ok else 1
print(f"{len(decks) - failed} passed, {failed} failed")
sys.exit(1 if failed else 0)
