#!/usr/bin/env python3
"""The help texts and the man page: `trainsim --help` and `trainsim CMD --help` for
each command exit 0 and print that command's usage; misuse still exits 2; the man page
renders without groff warnings and documents every command and option the help texts
list (so it cannot fall behind the program unnoticed).

Usage: check_help.py TRAINSIM MANPAGE   (exit 77 = skipped: no `man` on this machine)"""
import re
import shutil
import subprocess
import sys

exe, manpage = sys.argv[1], sys.argv[2]
failed = 0


def check(what, ok, detail=""):
    global failed
    print(("ok   " if ok else "FAIL ") + what + ("" if ok else f": {detail}"))
    failed += 0 if ok else 1


def run(*args):
    return subprocess.run([exe, *args], capture_output=True, text=True, timeout=60)


top = run("--help")
check("trainsim --help exits 0", top.returncode == 0, top.returncode)
commands = sorted(set(re.findall(r"^\s+trainsim ([a-z]+) ", top.stdout, re.M)))
check("trainsim --help lists the run and modes commands", {"run", "modes"} <= set(commands), commands)
texts = [top.stdout]
for cmd in commands:
    for flag in ("--help", "-h"):
        r = run(cmd, flag)
        check(f"trainsim {cmd} {flag} exits 0 with no error", r.returncode == 0 and r.stderr == "",
              f"exit {r.returncode}, stderr {r.stderr.strip()[:200]}")
        check(f"trainsim {cmd} {flag} prints the usage of {cmd}",
              r.stdout.startswith(f"usage: trainsim {cmd} "), r.stdout[:200])
        texts.append(r.stdout)


def undescribed(text):
    """Options and arguments of an argparse help text that have no description."""
    lines, bare = text.splitlines(), []
    for i, line in enumerate(lines):
        m = re.match(r"^  (\S.*?)(\s{2,}\S.*)?$", line)
        if not m or line.startswith("usage") or m.group(1).startswith("-h, --help"):
            continue
        nxt = lines[i + 1] if i + 1 < len(lines) else ""
        if m.group(2) is None and not re.match(r"^\s{10,}\S", nxt):
            bare.append(m.group(1))
    return bare


# the Python commands (argparse): every option and argument says what it does
for cmd in ("export", "plot"):
    if cmd in commands:
        bare = undescribed(run(cmd, "--help").stdout)
        check(f"trainsim {cmd} --help describes every option", not bare, bare)
r = run("run")
check("trainsim run without a deck still exits 2", r.returncode == 2, r.returncode)
r = run("nosuch", "--help")
check("an unknown command with --help still exits 2", r.returncode == 2, r.returncode)

if shutil.which("man") is None:
    print("skipped: no `man` to render the man page")
    sys.exit(77 if failed == 0 else 1)
m = subprocess.run(["man", "--warnings", "-l", manpage], capture_output=True, text=True,
                   env={"MANWIDTH": "100", "LC_ALL": "C.UTF-8", "PATH": "/usr/bin:/bin", "MANPAGER": "cat"})
check("the man page renders", m.returncode == 0 and "TRAINSIM(1)" in m.stdout, m.stderr[:200])
check("without groff warnings", m.stderr.strip() == "", m.stderr[:300])
page = m.stdout.replace("\u2010", "-").replace("\u2011", "-")
page = re.sub(r"-\n\s*", "-", page)   # words hyphenated at a line end
options = sorted(set(re.findall(r"(?<![\w-])(--?[a-zA-Z][\w-]*)", "\n".join(texts))))
for opt in options:
    check(f"the man page documents {opt}", re.search(r"(?<![\w-])" + re.escape(opt) + r"(?![\w-])", page) is not None)
for cmd in commands:
    check(f"the man page documents the {cmd} command", f"trainsim {cmd}" in page)
print("failed" if failed else "all passed")
sys.exit(1 if failed else 0)
