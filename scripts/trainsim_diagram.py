#!/usr/bin/python3
"""Draw a trainsim train as a block diagram (trainsim diagram DECK -o OUT.svg|png|pdf).

usage: trainsim_diagram.py DESCRIPTION.json -o OUT.svg|png|pdf

The description is what `trainsim diagram DECK --json FILE` writes: the deck read and
built by trainsim itself (src/io/trainsim_describe.f90), never re-parsed here. Nodes are
blocks (id, kind, inertia); elements are connectors between them labelled with their
id, type and key parameters (gear ratio, stiffness, backlash or clearance); a clearance
is marked in red on its connector; torques, prescribed speeds and motor voltages are
arrows into their node. Layout: each connected part of the train is a tree laid out
left to right from its first node (breadth-first layers), a chain on one row and each
branch on rows below; an element that closes a loop is drawn as an arc. Every part is
framed and numbered, so a node or group of nodes joined to nothing else is seen at a
glance. Drawn with matplotlib (Graphviz is not a dependency of trainsim).

In an SVG the text stays text, and each block, connector and arrow is a group whose id
is `node:ID`, `element:ID`, `load:K` (and `part:K` for the frames), so a drawing can
be checked or styled by id.
"""
import argparse
import json
import os
import sys
from collections import deque

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from trainsim_figures import key_unit, pretty  # noqa: E402

DX, DY = 3.6, 2.3          # layer and row spacing (drawing units)
BW, BH = 1.7, 1.05         # node block size
CLEARANCE_KEYS = ("half_backlash", "half_clearance", "clearance")


def fmt(x):
    return f"{x:.4g}"


def components(nodes, elements):
    """Connected parts of the train: lists of node ids in deck order, and for each node its part."""
    adj = {n["id"]: [] for n in nodes}
    for e in elements:
        adj[e["left"]].append(e["right"])
        adj[e["right"]].append(e["left"])
        for node in e.get("ports", {}).values():   # an n-port element's further ports (a carrier)
            adj[e["left"]].append(node)
            adj[node].append(e["left"])
    part, parts = {}, []
    for n in nodes:
        if n["id"] in part:
            continue
        k = len(parts)
        members, todo = [], deque([n["id"]])
        part[n["id"]] = k
        while todo:
            u = todo.popleft()
            members.append(u)
            for v in adj[u]:
                if v not in part:
                    part[v] = k
                    todo.append(v)
        parts.append(members)
    return parts, part


def layout(nodes, elements):
    """(x, y) of each node: per part a breadth-first tree from its first node in deck
    order; depth -> x, and rows by depth-first order (a node keeps its first child's row,
    each further child opens rows below). Returns positions, parts, tree edges, row spans."""
    order = {n["id"]: i for i, n in enumerate(nodes)}
    parts, _ = components(nodes, elements)
    adj = {n["id"]: [] for n in nodes}
    for e in elements:
        adj[e["left"]].append((e["right"], e["id"]))
        adj[e["right"]].append((e["left"], e["id"]))
        for key, node in e.get("ports", {}).items():   # a carrier: placed beside the element
            adj[e["left"]].append((node, f"{e['id']}:{key}"))
            adj[node].append((e["left"], f"{e['id']}:{key}"))
    pos, tree_edges, spans = {}, set(), []
    row0 = 0
    for members in parts:
        root = min(members, key=order.get)
        depth, children = {root: 0}, {u: [] for u in members}
        todo = deque([root])
        while todo:
            u = todo.popleft()
            for v, eid in sorted(adj[u], key=lambda p: order[p[0]]):
                if v not in depth:
                    depth[v] = depth[u] + 1
                    children[u].append(v)
                    tree_edges.add(eid)
                    todo.append(v)
        rows = {}
        next_row = [row0]

        def place(u):
            rows[u] = next_row[0]
            for i, c in enumerate(children[u]):
                if i > 0:
                    next_row[0] += 1
                place(c)

        place(root)
        for u in members:
            pos[u] = (depth[u] * DX, -rows[u] * DY)
        spans.append((row0, next_row[0], max(depth.values())))
        row0 = next_row[0] + 2      # a free row between parts (room for the loads' arrows)
    return pos, parts, tree_edges, spans


def edge_points(c0, c1):
    """Where the straight line between two block centres leaves the blocks."""
    dx, dy = c1[0] - c0[0], c1[1] - c0[1]
    t = min(BW / 2 / abs(dx) if dx else 1e9, BH / 2 / abs(dy) if dy else 1e9, 0.45)
    return (c0[0] + t * dx, c0[1] + t * dy), (c1[0] - t * dx, c1[1] - t * dy)


def element_lines(e, units):
    """The connector's label: id, type, then its key parameters with units."""
    p, t = e["params"], e["type"]
    lines = [e["id"], t.replace("_", " ")]
    if "gear_ratio" in p:
        lines.append(f"ratio {fmt(p['gear_ratio'])}")
    if "teeth" in p:
        lines.append(f"{fmt(p['teeth'])} teeth")
    for key, sym in (("stiffness", "k"), ("mean_mesh_stiffness", "k mean")):
        if key in p:
            u = key_unit("stiffness", units, t)
            lines.append(f"{sym} = {fmt(p[key])} {pretty(u or '')}".rstrip())
            break
    fit = e.get("choices", {}).get("stiffness_fit")
    if fit and fit != "constant":
        lines.append(f"stiffness: {fit} fit")
    if t in ("shaft", "damper") and p.get("damping", 0.0) > 0:
        lines.append(f"c = {fmt(p['damping'])} {pretty(key_unit('damping', units, t))}")
    return lines


def clearance_text(e, units):
    p = e["params"]
    for key in CLEARANCE_KEYS:
        if key in p:
            sym = {"half_backlash": "backlash b", "half_clearance": "clearance b", "clearance": "clearance"}[key]
            return f"{sym} = {fmt(p[key])} {pretty(key_unit(key, units, e['type']))}"
    return None


def load_text(ld, units):
    q = ld["quantity"]
    sym = {"torque": "torque", "speed": "prescribed speed", "voltage": "voltage"}.get(q, q)
    unit = {"torque": key_unit("value", units, quantity="torque"), "speed": "rad/s", "voltage": "V"}.get(q, "")
    keys = ", ".join(f"{k} {v}" for k, v in ld["keys"].items() if k not in ("times", "values", "table_file"))
    if "table_file" in ld["keys"]:
        keys = f"table {ld['keys']['table_file']}"
    elif "times" in ld["keys"]:
        keys = "table"
    return f"{sym} [{pretty(unit)}]: {ld['kind']}" + (f"\n{keys}" if keys else "")


def draw(desc, out):
    import matplotlib
    matplotlib.use("Agg")
    matplotlib.rcParams["svg.fonttype"] = "none"     # text stays text in an SVG
    import matplotlib.pyplot as plt
    from matplotlib.patches import FancyArrowPatch, FancyBboxPatch, Rectangle

    units = desc["units"]["name"]
    nodes, elements, loads = desc["nodes"], desc["elements"], desc.get("loads", [])
    pos, parts, tree_edges, spans = layout(nodes, elements)
    max_depth = max(s[2] for s in spans)
    n_rows = spans[-1][1] + 1
    x_lo, x_hi = -BW / 2 - 0.7, max_depth * DX + BW / 2 + 2.6     # room for a load's text on the right
    y_lo, y_hi = -(n_rows - 1) * DY - BH / 2 - 1.4, BH / 2 + 1.6
    scale = 0.62                                                    # inches per drawing unit
    fig = plt.figure(figsize=(min((x_hi - x_lo) * scale, 40), min((y_hi - y_lo) * scale + 1.1, 60)))
    top = 1.0 - 0.55 / fig.get_figheight()
    bottom = 0.45 / fig.get_figheight()
    ax = fig.add_axes([0, bottom, 1, top - bottom])
    ax.set_xlim(x_lo, x_hi)
    ax.set_ylim(y_lo, y_hi)
    ax.set_aspect("equal")
    ax.axis("off")
    title = desc.get("title") or os.path.basename(desc.get("deck_file", ""))
    fig.suptitle(f"{title}\n{desc.get('deck_file', '')} · {len(nodes)} nodes, {len(elements)} elements, "
                 f"{len(parts)} part{'s' if len(parts) > 1 else ''} · units {units}", fontsize=9)

    # frames of the parts (drawn only when there is more than one)
    if len(parts) > 1:
        for k, ((r0, r1, d), members) in enumerate(zip(spans, parts)):
            y_top, y_bot = -r0 * DY + BH / 2 + 1.4, -r1 * DY - BH / 2 - 1.25
            x_right = d * DX + BW / 2 + 2.2
            frame = Rectangle((-BW / 2 - 0.5, y_bot), x_right + BW / 2 + 0.5, y_top - y_bot, fill=False,
                              ls="--", lw=0.9, ec="0.45")
            frame.set_gid(f"part:{k + 1}")
            ax.add_patch(frame)
            ax.text(x_right - 0.1, y_bot + 0.08, f"part {k + 1} of {len(parts)}: not connected to the other "
                    f"part{'s' if len(parts) > 2 else ''}", fontsize=7, color="0.35", va="bottom", ha="right")

    # elements: connectors with their labels; clearances in red
    pair_count = {}
    for e in elements:
        (x0, y0), (x1, y1) = pos[e["left"]], pos[e["right"]]
        key = tuple(sorted((e["left"], e["right"])))
        pair_count[key] = pair_count.get(key, 0) + 1
        clr = clearance_text(e, units)
        colour = "C3" if clr else "0.15"
        if e["id"] in tree_edges and pair_count[key] == 1:
            rad = 0.0
        elif pair_count[key] > 1:   # a further element between the same two nodes: a wider arc each
            rad = 1.0 * (pair_count[key] - 1)
        else:                       # an element that closes a loop of the train
            rad = 0.45
        (xa, ya), (xb, yb) = edge_points((x0, y0), (x1, y1))
        conn = FancyArrowPatch((xa, ya), (xb, yb), arrowstyle="-", connectionstyle=f"arc3,rad={rad:.2f}",
                               lw=2.0 if clr else 1.6, color=colour, shrinkA=0, shrinkB=0, zorder=1)
        conn.set_gid(f"element:{e['id']}")
        ax.add_patch(conn)
        # the middle of the connector (of matplotlib's arc3 Bezier curve)
        xm = 0.5 * (xa + xb) + 0.5 * rad * (yb - ya)
        ym = 0.5 * (ya + yb) - 0.5 * rad * (xb - xa)
        lines = element_lines(e, units)
        extra = lines[2:] + ([clr] if clr else [])
        box = dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.9)
        if rad == 0.0:   # id and type above the connector, the parameters below it
            ax.text(xm, ym + 0.22, "\n".join(lines[:2]), ha="center", va="bottom", fontsize=7, zorder=3,
                    fontweight="bold", color=colour, bbox=box, gid=f"element-label:{e['id']}")
            if extra:
                ax.text(xm, ym - 0.22, "\n".join(extra), ha="center", va="top", fontsize=6.2, zorder=3,
                        color=colour, bbox=box)
        else:            # an arc: everything below (or above) its middle, clear of the straight one
            side = -1 if ym <= 0.5 * (ya + yb) else 1
            ax.text(xm, ym + side * 0.12, f"{lines[0]} ({lines[1]})" + ("\n" + "\n".join(extra) if extra else ""),
                    ha="center", va="top" if side < 0 else "bottom", fontsize=6.2, zorder=3, color=colour, bbox=box,
                    gid=f"element-label:{e['id']}")
        for key, node in e.get("ports", {}).items():   # a further port (a carrier): dashed, to its node
            (xc, yc), _ = edge_points(pos[node], (xm, ym))
            ax.plot([xm, xc], [ym, yc], ls="--", lw=1.0, color="0.35", zorder=1, gid=f"port:{e['id']}:{key}")
            ax.text(0.5 * (xm + xc) + 0.06, 0.5 * (ym + yc), key, fontsize=6, color="0.35", ha="left",
                    va="center", zorder=3)
        if clr:   # the clearance symbol: a gap between two bars on the connector
            ax.plot([xm - 0.09, xm - 0.09], [ym - 0.16, ym + 0.16], color="C3", lw=2.2, zorder=4)
            ax.plot([xm + 0.09, xm + 0.09], [ym - 0.16, ym + 0.16], color="C3", lw=2.2, zorder=4)

    # nodes: blocks
    face = {"inertia": "#dce9f5", "dc_motor": "#fbe3c8", "fixed": "#d9d9d9"}
    for n in nodes:
        x, y = pos[n["id"]]
        box = FancyBboxPatch((x - BW / 2, y - BH / 2), BW, BH, boxstyle="round,pad=0.04",
                             fc=face.get(n["type"], "#e8e8e8"), ec="0.2", lw=1.1, zorder=2,
                             hatch="//" if n["fixed"] else None)
        box.set_gid(f"node:{n['id']}")
        ax.add_patch(box)
        lines = ["fixed (ground)"] if n["fixed"] else [n["type"].replace("_", " ")]
        if "inertia" in n["params"]:
            lines.append(f"J = {fmt(n['params']['inertia'])} {pretty(key_unit('inertia', units))}")
        if n["params"].get("damping", 0.0) > 0:
            lines.append(f"c = {fmt(n['params']['damping'])} {pretty(key_unit('damping', units, 'shaft'))}")
        ax.text(x, y + BH / 2 - 0.1, n["id"], ha="center", va="top", fontsize=8, fontweight="bold", zorder=3,
                gid=f"node-label:{n['id']}")
        ax.text(x, y + BH / 2 - 0.36, "\n".join(lines), ha="center", va="top", fontsize=6.2, zorder=3)

    # loads, prescribed speeds, voltages: arrows into the top of their node
    per_node = {}
    colours = {"torque": "C0", "speed": "C2", "voltage": "C1"}
    for k, ld in enumerate(loads):
        if ld["node"] not in pos:
            continue
        x, y = pos[ld["node"]]
        i = per_node.get(ld["node"], 0)
        per_node[ld["node"]] = i + 1
        xa = x - 0.45 + 0.9 * i
        c = colours.get(ld["quantity"], "k")
        arrow = FancyArrowPatch((xa, y + BH / 2 + 0.75), (xa, y + BH / 2 + 0.04), arrowstyle="-|>",
                                mutation_scale=12, lw=1.4, color=c, zorder=3)
        arrow.set_gid(f"load:{k + 1}")
        ax.add_patch(arrow)
        ax.text(xa + 0.06, y + BH / 2 + 0.8, load_text(ld, units), fontsize=6, color=c, ha="left", va="bottom",
                zorder=3)

    # the key to the colours
    from matplotlib.lines import Line2D
    handles = [Line2D([], [], color="0.15", lw=1.6, label="element"),
               Line2D([], [], color="C3", lw=2.0, label="element with a clearance (red bars: the gap)")]
    for q in ("torque", "speed", "voltage"):
        if any(ld["quantity"] == q for ld in loads):
            handles.append(Line2D([], [], color=colours[q], marker=">", lw=1.4,
                                  label={"torque": "applied torque", "speed": "prescribed speed",
                                         "voltage": "motor voltage"}[q]))
    fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=6.5, frameon=False)
    fig.savefig(out)
    plt.close(fig)
    return len(parts)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="trainsim diagram", description=__doc__.split("\n\n")[0])
    ap.add_argument("description", help="the JSON of `trainsim diagram DECK --json FILE`")
    ap.add_argument("-o", "--output", required=True)
    a = ap.parse_args(argv)
    ext = os.path.splitext(a.output)[1].lower()
    if ext not in (".svg", ".png", ".pdf"):
        print(f"trainsim diagram: error: output '{a.output}' must end in .svg, .png or .pdf", file=sys.stderr)
        return 2
    try:
        with open(a.description, encoding="utf-8") as f:
            desc = json.load(f)
    except (OSError, ValueError) as e:
        print(f"trainsim diagram: error: cannot read the description '{a.description}': {e}", file=sys.stderr)
        return 2
    try:
        n_parts = draw(desc, a.output)
    except OSError as e:
        print(f"trainsim diagram: error: cannot write '{a.output}': {e}", file=sys.stderr)
        return 2
    print(f"trainsim diagram: {len(desc['nodes'])} nodes, {len(desc['elements'])} elements, {n_parts} "
          f"part{'s' if n_parts > 1 else ''}: {a.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
