#!/usr/bin/python3
"""trainsim diagram: the train drawn from the deck alone.

- Every bundled deck (inputs/*.nml) is drawn to SVG with its description (--json): exit
  0; the description holds exactly the deck's &node and &element groups (ids, in file
  order; the default ids n<k>, e<k>; an element's left/right as the deck gives them),
  read here from the deck text by a regular expression independent of trainsim's
  parser; the SVG has a block `node:ID` and a connector `element:ID` for each, and a
  <text> with each id (text stays text: svg.fonttype none).
- A deck of two unconnected parts (a motor-coupling-hub-frame chain and a separate
  gear pair with a parallel spring) is described as two connected components, and
  drawn as two framed parts (`part:1`, `part:2`) whose outlines do not overlap, each
  holding the blocks of its own nodes.
- A choice key (the keyed joint's stiffness_fit) is described and drawn by its word.
- A bad deck ends with exit 2 and the same message as `trainsim run` gives for it; a
  bad output name ends with exit 2 before anything is read.

usage: check_diagram.py TRAINSIM_EXE
"""
import glob
import json
import os
import re
import shutil
import subprocess
import tempfile
import xml.etree.ElementTree as ET

from clicheck import check, EXE, finish
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SVG = "{http://www.w3.org/2000/svg}"

TWO_PARTS = """! two trains in one deck
&run title = 'two unconnected parts', t_end = 0.01, dt = 1e-5 /
&node id = 'motor', type = 'dc_motor', inertia = 0.002, damping = 1e-4, torque_constant = 0.5,
      inductance = 0.002, resistance = 0.5, back_emf_constant = 0.0565 /
&node id = 'hub', type = 'inertia', inertia = 0.01 /
&node id = 'frame', type = 'fixed' /
&node id = 'pinion', type = 'inertia', inertia = 0.01 /
&node id = 'wheel', type = 'inertia', inertia = 0.5 /
&element id = 'coupling', type = 'clearance_coupling', left = 'motor', right = 'hub', clearance = 0.01,
         stiffness = 1e4, contact_damping = 1 /
&element id = 'mount', type = 'shaft', left = 'hub', right = 'frame', stiffness = 1e5 /
&element id = 'mesh', type = 'ideal_gear', left = 'pinion', right = 'wheel', stiffness = 2e5, rb_driver = 1, rb_driven = 3 /
&element id = 'spring', type = 'shaft', left = 'pinion', right = 'wheel', stiffness = 10 /
&load node = 'motor', quantity = 'voltage', kind = 'constant', value = 12 /
&load node = 'pinion', quantity = 'speed', kind = 'constant', value = 10 /
&load node = 'wheel', kind = 'ramp', value1 = -50, t1 = 0.01 /
"""


# trainsim's own temporary files go to a folder of this test's alone: the check that none
# is left must not see those of another `trainsim diagram` running beside it (ctest -j,
# other users of /tmp), which is how it once failed under load.
PRIVATE_TMP = tempfile.mkdtemp(prefix="check_diagram-")


def trainsim(*args):
    env = dict(os.environ, TMPDIR=PRIVATE_TMP)
    return subprocess.run([EXE] + list(args), capture_output=True, text=True, timeout=300, env=env)


def deck_groups(text):
    """[(name, {key: first value})] of a deck's groups, by a regular expression (comments
    dropped, quoted strings kept whole); independent of trainsim's parser."""
    text = "\n".join(re.sub(r"^((?:'[^']*'|\"[^\"]*\"|[^'\"!])*)!.*$", r"\1", line) for line in text.splitlines())
    out = []
    for m in re.finditer(r"&(\w+)((?:'[^']*'|\"[^\"]*\"|[^/'\"])*)/", text):
        keys = {}
        for k, v in re.findall(r"(\w+)\s*=\s*('[^']*'|\"[^\"]*\"|[^,\s]+)", m.group(2)):
            keys.setdefault(k.lower(), v.strip("'\""))
        out.append((m.group(1).lower(), keys))
    return out


def svg_groups(path):
    """{gid: element} of the SVG's groups, and the text of its <text> elements."""
    root = ET.parse(path).getroot()
    groups = {g.get("id"): g for g in root.iter(SVG + "g") if g.get("id")}
    texts = ["".join(t.itertext()) for t in root.iter(SVG + "text")]
    return groups, texts


def bbox(group):
    """Bounding box of the path coordinates in a group (SVG user units)."""
    xs, ys = [], []
    for p in group.iter(SVG + "path"):
        nums = [float(x) for x in re.findall(r"-?\d+(?:\.\d+)?(?:e-?\d+)?", p.get("d", ""))]
        xs += nums[0::2]
        ys += nums[1::2]
    return min(xs), min(ys), max(xs), max(ys)


def components(desc):
    part = {n["id"]: n["id"] for n in desc["nodes"]}

    def find(u):
        while part[u] != u:
            u = part[u]
        return u
    for e in desc["elements"]:
        part[find(e["left"])] = find(e["right"])
    comps = {}
    for n in desc["nodes"]:
        comps.setdefault(find(n["id"]), []).append(n["id"])
    return list(comps.values())


with tempfile.TemporaryDirectory() as tmp:
    decks = sorted(glob.glob(os.path.join(ROOT, "inputs", "*.nml")))
    check(f"{len(decks)} bundled decks", len(decks) >= 10)
    for deck in decks:
        name = os.path.basename(deck)
        svg, js = os.path.join(tmp, name + ".svg"), os.path.join(tmp, name + ".json")
        r = trainsim("diagram", deck, "-o", svg, "--json", js)
        check(f"{name}: trainsim diagram exits 0 ({r.stderr.strip()[-200:]})", r.returncode == 0)
        if r.returncode != 0:
            continue
        with open(js, encoding="utf-8") as f:
            desc = json.load(f)
        with open(deck, encoding="utf-8") as f:
            groups = deck_groups(f.read())
        node_ids = [g.get("id", f"n{k + 1}") for k, g in enumerate(g for n, g in groups if n == "node")]
        els = [g for n, g in groups if n == "element"]
        el_ids = [g.get("id", f"e{k + 1}") for k, g in enumerate(els)]
        # a &planetary stage expands (D-93) into its nodes and meshes after the deck's own
        for k, g in enumerate(g for n, g in groups if n == "planetary"):
            sid, npl = g.get("id", f"planetary{k + 1}"), int(g["planets"])
            node_ids += [f"{sid}_{m}" for m in ("sun", "ring", "carrier") if m not in g]
            node_ids += [f"{sid}_planet{j}" for j in range(1, npl + 1)]
            el_ids += [f"{sid}_{m}_planet{j}" for j in range(1, npl + 1) for m in ("sun", "ring")]
        check(f"{name}: described nodes {[n['id'] for n in desc['nodes']]} are the deck's",
              [n["id"] for n in desc["nodes"]] == node_ids)
        # a &controller with a sequence adds its positioner element (D-76), after the deck's
        ctls = [g for n, g in groups if n == "controller"]
        pos_ids = [g.get("id", f"c{k + 1}") for k, g in enumerate(ctls)
                   if str(g.get("sequence", "")).strip(".").lower() in ("true", "t")]
        check(f"{name}: described elements {[e['id'] for e in desc['elements']]} are the deck's",
              [e["id"] for e in desc["elements"]] == el_ids + pos_ids)
        ends = all(e.get(side) in (None, d[side]) for e, d in zip(els, desc["elements"]) for side in ("left", "right"))
        check(f"{name}: each element joins the nodes the deck names", ends)
        loads = [g for n, g in groups if n == "load"]
        check(f"{name}: {len(loads)} loads described on their nodes",
              [g["node"] for g in loads] == [ld["node"] for ld in desc["loads"]])
        gids, texts = svg_groups(svg)
        missing = [f"node:{i}" for i in node_ids if f"node:{i}" not in gids]
        missing += [f"element:{i}" for i in el_ids if f"element:{i}" not in gids]
        check(f"{name}: the SVG has a block for each node and a connector for each element (missing {missing})",
              not missing)
        unnamed = [i for i in node_ids + el_ids if not any(t == i or t.startswith(i + " (") for t in texts)]
        check(f"{name}: a <text> of the SVG names each node and element (not: {unnamed})", not unnamed)

    deck = os.path.join(tmp, "two_parts.nml")
    with open(deck, "w", encoding="utf-8") as f:
        f.write(TWO_PARTS)
    svg, js = os.path.join(tmp, "two_parts.svg"), os.path.join(tmp, "two_parts.json")
    r = trainsim("diagram", deck, "-o", svg, "--json", js)
    check(f"two-part deck drawn ({r.stdout.strip()} {r.stderr.strip()})", r.returncode == 0)
    with open(js, encoding="utf-8") as f:
        desc = json.load(f)
    comps = sorted(sorted(c) for c in components(desc))
    check(f"the description has two connected components {comps}",
          comps == [["frame", "hub", "motor"], ["pinion", "wheel"]])
    gids, texts = svg_groups(svg)
    check("the drawing frames two parts (part:1, part:2, no part:3)",
          "part:1" in gids and "part:2" in gids and "part:3" not in gids)
    p1, p2 = bbox(gids["part:1"]), bbox(gids["part:2"])
    apart = p1[3] < p2[1] or p2[3] < p1[1] or p1[2] < p2[0] or p2[2] < p1[0]
    check(f"the two parts' frames do not overlap ({p1}, {p2})", apart)

    def inside(b, frame):
        return frame[0] <= b[0] and b[2] <= frame[2] and frame[1] <= b[1] and b[3] <= frame[3]
    for members, frame in ((["motor", "hub", "frame"], p1), (["pinion", "wheel"], p2)):
        check(f"the blocks of {members} lie inside their own part's frame",
              all(inside(bbox(gids[f"node:{m}"]), frame) for m in members))
    check("the parallel spring and the mesh are both drawn", "element:spring" in gids and "element:mesh" in gids)
    check("the clearance is marked ('clearance = 0.01 rad')", any("clearance = 0.01 rad" in t for t in texts))
    check("the voltage, speed and torque are drawn as arrows load:1..3",
          all(f"load:{k}" in gids for k in (1, 2, 3)))

    # a choice key is described and drawn by its word
    fit = os.path.join(tmp, "fit.nml")
    with open(os.path.join(ROOT, "inputs", "start_stop_two_clearances.nml"), encoding="utf-8") as f:
        text = f.read()
    check("the start-stop deck's key has 'stiffness = 2.03e6 /'", "stiffness = 2.03e6 /" in text)
    with open(fit, "w", encoding="utf-8") as f:
        f.write(text.replace("stiffness = 2.03e6 /", "stiffness_fit = 'tight', key_length = 2.0 /"))
    svg, js = os.path.join(tmp, "fit.svg"), os.path.join(tmp, "fit.json")
    r = trainsim("diagram", fit, "-o", svg, "--json", js)
    with open(js, encoding="utf-8") as f:
        key = [e for e in json.load(f)["elements"] if e["id"] == "key"][0]
    check(f"stiffness_fit described by its word {key['choices']}", key["choices"] == {"stiffness_fit": "tight"})
    check("... and drawn ('stiffness: tight fit')", "stiffness: tight fit" in svg_groups(svg)[1])

    bad = os.path.join(tmp, "bad.nml")
    with open(bad, "w", encoding="utf-8") as f:
        f.write(TWO_PARTS.replace("inertia = 0.01 /", "inertia = -0.01 /", 1))
    r1 = trainsim("diagram", bad, "-o", os.path.join(tmp, "bad.svg"))
    r2 = trainsim("run", bad, "--no-output")
    check(f"a bad deck: exit 2, the message of trainsim run ({r1.stderr.strip()})",
          r1.returncode == 2 and r2.returncode == 2 and r1.stderr == r2.stderr and "bad.nml" in r1.stderr
          and not os.path.exists(os.path.join(tmp, "bad.svg")))
    r = trainsim("diagram", deck, "-o", os.path.join(tmp, "x.jpg"))
    check(f"an unsupported format: exit 2 ({r.stderr.strip()})", r.returncode == 2 and ".svg, .png or .pdf" in r.stderr)
    r = trainsim("diagram", deck)
    check(f"no -o: exit 2 ({r.stderr.strip()})", r.returncode == 2)
    for ext, magic in ((".png", b"\x89PNG"), (".pdf", b"%PDF")):
        out = os.path.join(tmp, "tp" + ext)
        r = trainsim("diagram", deck, "-o", out)
        with open(out, "rb") as f:
            check(f"{ext} written", r.returncode == 0 and f.read(4) == magic)
    left = [x for x in os.listdir(PRIVATE_TMP) if x.startswith("trainsim-diagram-")]
    check(f"no temporary description left in $TMPDIR ({left[:3]})", not left)
    shutil.rmtree(PRIVATE_TMP, ignore_errors=True)

finish()
