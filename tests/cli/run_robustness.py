#!/usr/bin/python3
"""Robust runs: deck text and value limits, -o safety, temporary files, write errors,
interrupts.

Usage (as CTest runs it, cwd = repo root):

    /usr/bin/python3 tests/cli/run_robustness.py <path to trainsim> [GROUP ...]

GROUP is one of: text, limits, output, concurrent, diskfull, interrupt (default: all).
Each check prints ok/FAIL with its reason; exit status 1 if any failed, 77 (CTest's
skip code) if the only group asked for cannot run here (diskfull needs to mount a
tmpfs, which needs root).
"""

import glob
import os
import signal
import stat
import subprocess
import sys
import tempfile
import time

import h5py

FORBIDDEN = ["Backtrace", "Error termination", "Fortran runtime error", "SIGSEGV", "SIGFPE",
             "Program received signal"]

RUN = "&run t_end = 0.01, dt = 1.0e-4 /\n"
NODES = ("&node id = 'a', type = 'inertia', inertia = 5.0 /\n"
         "&node id = 'b', type = 'inertia', inertia = 11.0 /\n")
SHAFT = "&element id = 's1', type = 'shaft', stiffness = 1.0e5 /\n"
GOOD = RUN + NODES + SHAFT

# Runs long enough to be interrupted (a minute or more in Release; stopped after 1 s).
LONG = {"rk4": "&run t_end = 1000.0, dt = 1.0e-5, output_interval = 1.0e-2 /\n",
        "cvode-adams": "&run t_end = 1.0e5, dt = 1.0e-5, integrator = 'cvode-adams', output_interval = 1.0 /\n"}

results = []


def check(name, ok, detail=""):
    results.append(ok)
    print("%s  %s%s" % ("ok  " if ok else "FAIL", name, "" if ok or not detail else "\n        " + detail))


def run(exe, args, cwd, timeout=60):
    """Exit status, stdout, stderr; a hang is reported as status -999."""
    try:
        proc = subprocess.run([exe] + args, cwd=cwd, capture_output=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return -999, "", "timed out after %d s" % timeout
    return proc.returncode, proc.stdout.decode("utf-8", "replace"), proc.stderr.decode("utf-8", "replace")


def write(path, data):
    with open(path, "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode("utf-8"))


def parts_in(d):
    return glob.glob(os.path.join(d, "*.part"))


def crashed(*texts):
    return [s for s in FORBIDDEN if any(s in t for t in texts)]


def expect_error(exe, name, deck, must, code=2, args=None):
    """The deck (text or bytes) fails with `code`; stderr holds every string of `must`."""
    with tempfile.TemporaryDirectory(prefix="trainsim-rob-") as tmp:
        write(os.path.join(tmp, "deck.nml"), deck)
        out = os.path.join(tmp, "out.h5")
        rc, so, se = run(exe, args or ["run", "deck.nml", "-o", out], tmp)
        problems = []
        if rc != code:
            problems.append("exit %d, expected %d" % (rc, code))
        problems += ["stderr lacks %r" % m for m in must if m not in se]
        problems += ["crash: %r" % c for c in crashed(so, se)]
        if os.path.exists(out) or parts_in(tmp):
            problems.append("an output or temporary file was left")
        check(name, not problems, "; ".join(problems) + " | stderr: " + se.strip()[-300:])


# ---------------------------------------------------------------------------- text
def group_text(exe):
    # NUL: the reader must say what and where, not complain about the text around it.
    expect_error(exe, "NUL byte rejected with file:line and column",
                 (RUN + NODES).encode() + b"&element id = 's1',\x00 type = 'shaft', stiffness = 1.0e5 /\n",
                 ["deck.nml:4:", "NUL byte at column 20"])
    # Invalid UTF-8 would end up in the HDF5 strings.
    for what, bad in [("a lone 0xFF", b"\xff"), ("a truncated sequence", b"\xe2\x82"),
                      ("an overlong '/'", b"\xc0\xaf"), ("a UTF-16 surrogate", b"\xed\xa0\x80"),
                      ("a code point above U+10FFFF", b"\xf4\x90\x80\x80")]:
        expect_error(exe, "invalid UTF-8 (%s) rejected with file:line" % what,
                     b"&run title = 'rig " + bad + b"', t_end = 0.01, dt = 1.0e-4 /\n" + (NODES + SHAFT).encode(),
                     ["deck.nml:1:", "invalid UTF-8 at column 19", "decks must be UTF-8"])
    # Valid UTF-8 (and a byte-order mark) is text: accepted and stored as UTF-8.
    title = "Prüfstand – Zahnrad 齿轮 🚗"
    with tempfile.TemporaryDirectory(prefix="trainsim-rob-") as tmp:
        write(os.path.join(tmp, "deck.nml"),
              b"\xef\xbb\xbf" + ("&run title = '%s', t_end = 0.01, dt = 1.0e-4 /\n" % title).encode() +
              (NODES + SHAFT).encode())
        out = os.path.join(tmp, "out.h5")
        rc, so, se = run(exe, ["run", "deck.nml", "-o", out], tmp)
        ok = rc == 0
        detail = "exit %d: %s" % (rc, se.strip()[-300:])
        if ok:
            with h5py.File(out, "r") as f:
                attr = f.attrs["title"]
                stored = attr.decode("utf-8") if isinstance(attr, bytes) else str(attr)
                cset = h5py.h5a.open(f.id, b"title").get_type().get_cset()
            ok = stored == title and cset == h5py.h5t.CSET_UTF8
            detail = "title %r, cset %d" % (stored, cset)
        check("UTF-8 title with a byte-order mark accepted, stored and marked as UTF-8", ok, detail)


# -------------------------------------------------------------------------- limits
def group_limits(exe):
    runline = "&run t_end = 0.01, dt = 1.0e-4, {} /\n"
    # Non-finite and overflowing reals, in a scalar key, a node key and an array.
    for text in ["nan", "NaN", "inf", "-Infinity", "1e400", "-1.0d999", "1e-400"]:
        expect_error(exe, "t_end = %s rejected naming the key" % text,
                     "&run t_end = %s, dt = 1.0e-4 /\n" % text + NODES + SHAFT,
                     ["deck.nml:1:", "key 't_end'", "expected a real number, got '%s'" % text])
    expect_error(exe, "inertia = inf rejected naming the key",
                 RUN + "&node id = 'a', type = 'inertia', inertia = inf /\n"
                 "&node id = 'b', type = 'inertia', inertia = 11.0 /\n" + SHAFT,
                 ["deck.nml:2:", "key 'inertia'", "got 'inf'"])
    expect_error(exe, "a table value of 1e999 rejected naming the key and value number",
                 GOOD + "&load node = 'a', kind = 'table', times = 0.0, 0.01, values = 1.0, 1e999 /\n",
                 ["deck.nml:5:", "key 'values' (value 2)", "out of range"])
    expect_error(exe, "an integer beyond the default integer range rejected",
                 GOOD + "&load node = 'a', kind = 'start_stop', value = 1.0, t_accel = 1e-3, t_cruise = 1e-3,\n"
                 "      t_decel = 1e-3, cycles = 99999999999 /\n",
                 ["deck.nml:6:", "key 'cycles'", "got '99999999999' (out of range)"])
    # output_interval: a sample budget instead of a hang / integer overflow.
    expect_error(exe, "output_interval = 1e-100 rejected (sample limit), naming the key",
                 runline.format("output_interval = 1e-100") + NODES + SHAFT,
                 ["deck.nml:1:", "key 'output_interval'", "more than 1e9 samples", "output limit"])
    expect_error(exe, "output_interval = 0 with 2e9 steps rejected (every step is a sample)",
                 "&run t_end = 2000.0, dt = 1.0e-6 /\n" + NODES + SHAFT,
                 ["deck.nml:1:", "output_interval = 0", "more than 1e9 samples"])
    # dt: step counts and time resolution, no overflow in the check itself.
    expect_error(exe, "dt = 1e-300 over 1e10 s rejected without overflow",
                 "&run t_end = 1.0e10, dt = 1.0e-300 /\n" + NODES + SHAFT,
                 ["deck.nml:1:", "key 'dt'", "1e12 steps"])
    expect_error(exe, "t_end = 1e300 rejected (time limit)",
                 "&run t_start = -1.0e300, t_end = 1.0e300, dt = 1.0e299 /\n" + NODES + SHAFT,
                 ["deck.nml:1:", "key 't_start'", "time limit"])
    expect_error(exe, "dt below the time resolution at t_start = 1e9 rejected",
                 "&run t_start = 1.0e9, t_end = 1.000000001e9, dt = 1.0e-8, output_interval = 1.0e-3 /\n" +
                 NODES + SHAFT,
                 ["deck.nml:1:", "key 'dt'", "too fine"])
    expect_error(exe, "a negative atol_speed is named as atol_speed",
                 runline.format("atol_speed = -1.0") + NODES + SHAFT,
                 ["deck.nml:1:", "key 'atol_speed'", "must be > 0"])
    expect_error(exe, "a negative settle_time is named as settle_time",
                 runline.format("settle_time = -1.0") + NODES + SHAFT,
                 ["deck.nml:1:", "key 'settle_time'", "must be >= 0"])
    # A huge output_interval: first and last sample only, with every integrator.
    for integ in ["rk4", "cvode-adams"]:
        with tempfile.TemporaryDirectory(prefix="trainsim-rob-") as tmp:
            write(os.path.join(tmp, "deck.nml"),
                  runline.format("integrator = '%s', output_interval = 1e100" % integ) + NODES + SHAFT +
                  "&initial node = 'a', speed = 1.0 /\n")
            out = os.path.join(tmp, "out.h5")
            rc, so, se = run(exe, ["run", "deck.nml", "-o", out], tmp)
            ok = rc == 0 and not crashed(so, se)
            detail = "exit %d: %s" % (rc, se.strip()[-300:])
            if ok:
                with h5py.File(out, "r") as f:
                    t = f["time"][...]
                ok = len(t) == 2 and t[0] == 0.0 and abs(t[-1] - 0.01) < 1e-12
                detail = "time = %r" % (t,)
            check("output_interval = 1e100 with %s: exit 0, first and last sample only" % integ, ok, detail)
    # The reproducers of /work/shared/repro in this area, in their own words.
    expect_error(exe, "repro B_output_interval_tiny: exit 2 naming output_interval",
                 "&run t_end = 0.01, dt = 1e-4, output_interval = 1e-100 /\n"
                 "&node id = 'a', type = 'inertia', inertia = 1.0 /\n"
                 "&node id = 'b', type = 'inertia', inertia = 1.0 /\n"
                 "&element id = 's', type = 'shaft', stiffness = 1e3 /\n",
                 ["deck.nml:1:", "output_interval"])


# -------------------------------------------------------------------------- output
def group_output(exe):
    with tempfile.TemporaryDirectory(prefix="trainsim-rob-") as tmp:
        write(os.path.join(tmp, "deck.nml"), GOOD)
        # symbolic link: refused, the link and its target untouched
        target = os.path.join(tmp, "target.h5")
        write(target, "precious")
        link = os.path.join(tmp, "link.h5")
        os.symlink(target, link)
        rc, so, se = run(exe, ["run", "deck.nml", "-o", link], tmp)
        ok = (rc == 2 and "symbolic link" in se and os.path.islink(link) and
              open(target).read() == "precious" and not parts_in(tmp) and not crashed(so, se))
        check("-o onto a symbolic link: exit 2, link and target untouched", ok, "exit %d: %s" % (rc, se.strip()))
        # a dangling link too (rename would replace the link)
        dangling = os.path.join(tmp, "dangling.h5")
        os.symlink(os.path.join(tmp, "nowhere.h5"), dangling)
        rc, so, se = run(exe, ["run", "deck.nml", "-o", dangling], tmp)
        ok = rc == 2 and os.path.islink(dangling) and not os.path.exists(os.path.join(tmp, "nowhere.h5"))
        check("-o onto a dangling symbolic link: exit 2, link kept", ok, "exit %d: %s" % (rc, se.strip()))
        # a directory
        os.mkdir(os.path.join(tmp, "dir.h5"))
        rc, so, se = run(exe, ["run", "deck.nml", "-o", "dir.h5"], tmp)
        ok = rc == 2 and "is a directory" in se and os.path.isdir(os.path.join(tmp, "dir.h5"))
        check("-o onto a directory: exit 2", ok, "exit %d: %s" % (rc, se.strip()))
        # an empty name
        rc, so, se = run(exe, ["run", "deck.nml", "-o", ""], tmp)
        check("-o '': exit 2 with a message", rc == 2 and "empty file name" in se, "exit %d: %s" % (rc, se.strip()))
    # Devices and pipes. As root, a trainsim without this check replaces /dev/null and
    # /dev/full by regular files (it happened while this test was written), so the test
    # uses its own device nodes, made like them (mknod needs root; a FIFO does not).
    with tempfile.TemporaryDirectory(prefix="trainsim-rob-") as tmp:
        write(os.path.join(tmp, "deck.nml"), GOOD)
        specials = [("a FIFO", "fifo", lambda p: os.mkfifo(p))]
        for name, minor in [("null", 3), ("full", 7)]:
            specials.append(("a character device like /dev/" + name, name,
                             lambda p, m=minor: os.mknod(p, 0o666 | stat.S_IFCHR, os.makedev(1, m))))
        for what, name, make in specials:
            path = os.path.join(tmp, name)
            try:
                make(path)
            except PermissionError:
                print("skip  -o onto %s: cannot create one here" % what)
                continue
            before = os.lstat(path)
            rc, so, se = run(exe, ["run", "deck.nml", "-o", path], tmp)
            after = os.lstat(path)
            ok = (rc == 2 and "not a regular file" in se and after.st_ino == before.st_ino and
                  stat.S_IFMT(after.st_mode) == stat.S_IFMT(before.st_mode) and not parts_in(tmp))
            check("-o onto %s: exit 2, left as it was, no temporary file" % what, ok,
                  "exit %d: %s %s" % (rc, se.strip(), parts_in(tmp)))
    # no output: the summary is printed, no file written, even if the deck names one
    for opt in [["--no-output"], ["-o", "-"]]:
        with tempfile.TemporaryDirectory(prefix="trainsim-rob-") as tmp:
            write(os.path.join(tmp, "deck.nml"),
                  "&run t_end = 0.01, dt = 1.0e-4, output = 'deck_out.h5' /\n" + NODES + SHAFT)
            rc, so, se = run(exe, ["run", "deck.nml"] + opt, tmp)
            ok = rc == 0 and "final state" in so and os.listdir(tmp) == ["deck.nml"] and "history written" not in so
            check("%s: exit 0, summary printed, no file (not even the deck's output)" % " ".join(opt), ok,
                  "exit %d, files %s: %s" % (rc, os.listdir(tmp), se.strip()))


# ---------------------------------------------------------------------- concurrent
def group_concurrent(exe):
    """Two runs on one -o path: each succeeds, the file is whole and one run's own."""
    n_samples = {}
    with tempfile.TemporaryDirectory(prefix="trainsim-rob-") as tmp:
        for name, t_end in [("a", 1.0), ("b", 1.5)]:
            write(os.path.join(tmp, name + ".nml"),
                  "&run title = '%s', t_end = %s, dt = 2.0e-6, output_interval = 1.0e-4 /\n" % (name, t_end) +
                  NODES + SHAFT + "&initial node = 'a', speed = 1.0 /\n")
            n_samples[name] = int(round(t_end / 1.0e-4)) + 1
        out = os.path.join(tmp, "out.h5")
        procs = [subprocess.Popen([exe, "run", n + ".nml", "-o", out], cwd=tmp, stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE) for n in ("a", "b")]
        outs = [p.communicate(timeout=300) for p in procs]
        rcs = [p.returncode for p in procs]
        errs = [e.decode() for _, e in outs]
        check("two runs on the same -o path both exit 0", rcs == [0, 0], "exits %s: %s" % (rcs, errs))
        ok = False
        detail = "no file"
        if os.path.isfile(out):
            try:
                with h5py.File(out, "r") as f:
                    title = f.attrs["title"]
                    title = title.decode() if isinstance(title, bytes) else str(title)
                    deck = f.attrs["deck"]
                    deck = deck.decode() if isinstance(deck, bytes) else str(deck)
                    nt = f["time"].shape[0]
                    nth = f["nodes/theta"].shape[0]
                ok = (title in n_samples and ("title = '%s'" % title) in deck and
                      nt == n_samples[title] and nth == nt)
                detail = "title %r, %d time rows, %d theta rows, expected %s" % (title, nt, nth, n_samples)
            except Exception as e:  # an unreadable file is the failure this test looks for
                detail = "unreadable: %s" % e
        check("the final file is one run's complete history (deck text matches its data)", ok, detail)
        check("no temporary file left by either run", not parts_in(tmp), str(parts_in(tmp)))


# ------------------------------------------------------------------------ diskfull
def group_diskfull(exe):
    """A disk that fills mid-run: exit 2 naming the file, no crash, no temporary file."""
    mnt = tempfile.mkdtemp(prefix="trainsim-full-")
    try:
        if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", mnt],
                          capture_output=True).returncode != 0:
            os.rmdir(mnt)
            print("skip  disk full: cannot mount a 64 kB tmpfs here (needs root)")
            return "skip"
        with tempfile.TemporaryDirectory(prefix="trainsim-rob-") as tmp:
            write(os.path.join(tmp, "deck.nml"),
                  "&run t_end = 2.0, dt = 1.0e-5 /\n" + NODES + SHAFT + "&initial node = 'a', speed = 1.0 /\n")
            out = os.path.join(mnt, "out.h5")
            # stdout and stderr to files, as in a batch job: the message must not be lost
            with open(os.path.join(tmp, "stdout"), "w") as fo, open(os.path.join(tmp, "stderr"), "w") as fe:
                rc = subprocess.run([exe, "run", "deck.nml", "-o", out], cwd=tmp, stdout=fo, stderr=fe,
                                    timeout=120).returncode
            so = open(os.path.join(tmp, "stdout")).read()
            se = open(os.path.join(tmp, "stderr")).read()
            problems = []
            if rc != 2:
                problems.append("exit %d, expected 2" % rc)
            if "cannot write output file '%s'" % out not in se:
                problems.append("stderr does not name the file")
            problems += ["crash: %r" % c for c in crashed(so, se)]
            if os.listdir(mnt):
                problems.append("left on the full disk: %s" % os.listdir(mnt))
            if "element s1" not in so:
                problems.append("the parameter block is missing from stdout")
            check("disk full mid-run: exit 2 naming the file, no crash, nothing left", not problems,
                  "; ".join(problems) + " | stderr: " + se.strip()[-400:])
    finally:
        subprocess.run(["umount", mnt], capture_output=True)
        if os.path.isdir(mnt):
            os.rmdir(mnt)


# ----------------------------------------------------------------------- interrupt
def group_interrupt(exe):
    for sig, code, integ in [(signal.SIGINT, 130, "rk4"), (signal.SIGTERM, 143, "rk4"),
                             (signal.SIGINT, 130, "cvode-adams")]:
        with tempfile.TemporaryDirectory(prefix="trainsim-rob-") as tmp:
            write(os.path.join(tmp, "deck.nml"), LONG[integ] + NODES + SHAFT + "&initial node = 'a', speed = 1.0 /\n")
            out = os.path.join(tmp, "out.h5")
            fo = open(os.path.join(tmp, "stdout"), "w")
            fe = open(os.path.join(tmp, "stderr"), "w")
            p = subprocess.Popen([exe, "run", "deck.nml", "-o", out], cwd=tmp, stdout=fo, stderr=fe)
            # The parameter block must reach the file while the run goes on (flushed),
            # not only when the program ends.
            seen = False
            deadline = time.time() + 20
            while time.time() < deadline and p.poll() is None:
                if "element s1" in open(os.path.join(tmp, "stdout")).read():
                    seen = True
                    break
                time.sleep(0.1)
            time.sleep(1.0)
            running = p.poll() is None
            p.send_signal(sig)
            try:
                rc = p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                p.kill()
                rc = p.wait()
            fo.close()
            fe.close()
            so = open(os.path.join(tmp, "stdout")).read()
            se = open(os.path.join(tmp, "stderr")).read()
            problems = []
            if not running:
                problems.append("the run ended before the signal (make LONG longer)")
            if not seen:
                problems.append("the parameter block was not in stdout while the run went on (not flushed)")
            if rc != code:
                problems.append("exit %d, expected %d" % (rc, code))
            if "interrupted at t = " not in se or signal.Signals(sig).name not in se:
                problems.append("stderr does not say interrupted by %s" % signal.Signals(sig).name)
            # what was computed is kept, marked incomplete (issue 20, item 8)
            if not os.path.exists(out):
                problems.append("the history computed so far was not kept")
            else:
                with h5py.File(out, "r") as f:
                    if f.attrs.get("status") != "interrupted" or int(f["run_stats"].attrs["completed"]) != 0:
                        problems.append("the kept file is not marked interrupted")
                    if not f["time"].shape[0] > 1:
                        problems.append("the kept file has no samples after the first")
            if parts_in(tmp):
                problems.append("temporary file left: %s" % parts_in(tmp))
            problems += ["crash: %r" % c for c in crashed(so, se)]
            check("%s during a %s run: exit %d, parameters on stdout, the history kept, marked interrupted" %
                  (signal.Signals(sig).name, integ, code), not problems,
                  "; ".join(problems) + " | stderr: " + se.strip()[-300:])


GROUPS = {"text": group_text, "limits": group_limits, "output": group_output,
          "concurrent": group_concurrent, "diskfull": group_diskfull, "interrupt": group_interrupt}


def main():
    if len(sys.argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    exe = os.path.abspath(sys.argv[1])
    names = sys.argv[2:] or list(GROUPS)
    skipped = [n for n in names if GROUPS[n](exe) == "skip"]
    failed = results.count(False)
    print("%d passed, %d failed" % (results.count(True), failed))
    if failed:
        return 1
    if skipped and not results:
        return 77
    return 0


if __name__ == "__main__":
    sys.exit(main())
