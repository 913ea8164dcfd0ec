"""A picture of the graph (rqt_graph's "Nodes/Topics (all)" view) as SVG for JupyterLab.

``graph_picture(ctx)`` returns a :class:`GraphPicture`; a notebook cell ending with it shows
the SVG (``_repr_svg_``). Nodes are ellipses, topics boxes, arrows go publisher -> topic ->
subscriber; an incompatible-QoS pair is drawn as a red dashed arrow labelled with the policy.
Actions are drawn as one box per action (client -> action -> server) instead of their five
hidden topics and services. Layout: columns by data-flow depth, no external tools needed.

Every node's own topics stay out of the picture as rqt_graph leaves them out by default:
``/rosout`` (and ``/clock``, ``/statistics``) by its "Debug" filter, ``/parameter_events`` by
its "Dead sinks" filter unless some visible node subscribes to it.
"""

from __future__ import annotations

from html import escape

from robocourse.bus.introspection import ACTION_MARK

#: topics rqt_graph's default "Debug" filter hides (its QUIET_NAMES that name topics)
DEBUG_TOPICS = ("/rosout", "/clock", "/statistics")


class GraphPicture:
    def __init__(self, svg: str, nodes, topics, edges):
        self.svg = svg
        self.nodes = nodes
        self.topics = topics
        self.edges = edges

    def _repr_svg_(self):
        return self.svg

    def __repr__(self) -> str:          # a text-only view (a saved notebook's text, a terminal): what it shows
        return f"<rqt_graph picture: {len(self.nodes)} nodes, {len(self.topics)} topics, {len(self.edges)} arrows (SVG)>"

    def save(self, path) -> str:
        with open(path, "w") as f:
            f.write(self.svg)
        return str(path)


def graph_edges(ctx, include_hidden: bool = False):
    """(nodes, topics, edges); edges are (src, dst, kind) with kind 'pub'/'sub'/'incompatible'/'action'."""
    from robocourse.bus.action import ActionClient, ActionServer

    ctx = ctx.context if hasattr(ctx, "get_fully_qualified_name") else ctx
    nodes = [n.get_fully_qualified_name() for n in ctx.nodes
             if include_hidden or not n.get_name().startswith("_")]
    node_set = set(nodes)
    topics, edges = [], []
    for t in sorted(ctx._topics.values(), key=lambda t: t.name):
        if ACTION_MARK in t.name or not (t.pubs or t.subs) or t.name in DEBUG_TOPICS:
            continue
        pubs = [p for p in t.pubs if p._node.get_fully_qualified_name() in node_set]
        subs = [s for s in t.subs if s._node.get_fully_qualified_name() in node_set]
        if not pubs and not subs or (t.name == "/parameter_events" and not subs):
            continue
        topics.append(t.name)
        for p in pubs:
            edges.append((p._node.get_fully_qualified_name(), t.name, "pub", ""))
        for s in subs:
            bad = [i for i in ctx.incompatibilities if i.subscription is s]
            ok = [p for p in s._pubs]
            if ok or not bad:
                edges.append((t.name, s._node.get_fully_qualified_name(), "sub", ""))
            for i in bad:
                edges.append((t.name, s._node.get_fully_qualified_name(), "incompatible",
                              f"QoS {i.policy.name}"))
    for n in ctx.nodes:
        fq = n.get_fully_qualified_name()
        if fq not in node_set:
            continue
        for w in n.waitables:
            if isinstance(w, ActionServer):
                box = w.action_name + " (action)"
                if box not in topics:
                    topics.append(box)
                edges.append((box, fq, "action", ""))
            elif isinstance(w, ActionClient):
                box = w.action_name + " (action)"
                if box not in topics:
                    topics.append(box)
                edges.append((fq, box, "action", ""))
    return nodes, topics, edges


def graph_picture(ctx, include_hidden: bool = False, title: str | None = None) -> GraphPicture:
    nodes, topics, edges = graph_edges(ctx, include_hidden)
    items = nodes + topics
    succ = {k: [] for k in items}
    for a, b, _kind, _ in edges:
        succ[a].append(b)
    indeg = {k: 0 for k in items}
    for a in succ:
        for b in succ[a]:
            indeg[b] += 1
    rank = {k: 0 for k in items}
    # longest-path layering with a bound on iterations (graphs may have cycles)
    for _ in range(len(items)):
        changed = False
        for a in items:
            for b in succ[a]:
                if rank[b] < rank[a] + 1 and rank[a] + 1 < 2 * len(items):
                    if b in nodes and a in nodes:
                        continue
                    rank[b] = rank[a] + 1
                    changed = True
        if not changed:
            break
    # topics sit in odd columns, nodes in even ones
    for k in items:
        is_topic = k in topics
        if (rank[k] % 2 == 1) != is_topic:
            rank[k] += 1
    cols = {}
    for k in items:
        cols.setdefault(rank[k], []).append(k)
    colw, rowh, margin = 210, 64, 30
    pos = {}
    height = max((len(v) for v in cols.values()), default=1) * rowh + 2 * margin + 20
    ordered = sorted(cols)
    for ci, r in enumerate(ordered):
        col = cols[r]
        top = (height - len(col) * rowh) / 2 + rowh / 2
        for i, k in enumerate(col):
            pos[k] = (margin + 90 + ci * colw, top + i * rowh)
    width = margin * 2 + 180 + max(0, len(ordered) - 1) * colw
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
           f'viewBox="0 0 {width} {height}" font-family="sans-serif" font-size="11">',
           '<defs><marker id="arr" viewBox="0 0 10 10" refX="10" refY="5" markerWidth="7" '
           'markerHeight="7" orient="auto"><path d="M0,0 L10,5 L0,10 z" fill="#444"/></marker>'
           '<marker id="arrbad" viewBox="0 0 10 10" refX="10" refY="5" markerWidth="7" '
           'markerHeight="7" orient="auto"><path d="M0,0 L10,5 L0,10 z" fill="#d62728"/></marker></defs>',
           f'<rect width="{width}" height="{height}" fill="white"/>']
    if title:
        out.append(f'<text x="{margin}" y="18" font-size="13" font-weight="bold">{escape(title)}</text>')

    def anchor(k, other):
        x, y = pos[k]
        ox = pos[other][0]
        return (x + 80 if ox > x else x - 80, y) if ox != x else (x, y + (15 if pos[other][1] > y else -15))

    for a, b, kind, label in edges:
        (x1, y1), (x2, y2) = anchor(a, b), anchor(b, a)
        if kind == "incompatible":
            out.append(f'<line x1="{x1:.0f}" y1="{y1:.0f}" x2="{x2:.0f}" y2="{y2:.0f}" stroke="#d62728" '
                       f'stroke-width="2" stroke-dasharray="6,4" marker-end="url(#arrbad)"/>')
            out.append(f'<text x="{(x1 + x2) / 2:.0f}" y="{(y1 + y2) / 2 - 5:.0f}" fill="#d62728" '
                       f'text-anchor="middle">{escape(label)} ✗</text>')
        else:
            dash = ' stroke-dasharray="3,3"' if kind == "action" else ""
            out.append(f'<line x1="{x1:.0f}" y1="{y1:.0f}" x2="{x2:.0f}" y2="{y2:.0f}" stroke="#444" '
                       f'stroke-width="1.3"{dash} marker-end="url(#arr)"/>')
    for k in nodes:
        x, y = pos[k]
        out.append(f'<ellipse cx="{x:.0f}" cy="{y:.0f}" rx="80" ry="17" fill="#cfe2f3" stroke="#1f4e79"/>')
        out.append(f'<text x="{x:.0f}" y="{y + 4:.0f}" text-anchor="middle">{escape(k)}</text>')
    for k in topics:
        x, y = pos[k]
        fill = "#fde9c9" if k.endswith("(action)") else "#e8f5e9"
        out.append(f'<rect x="{x - 80:.0f}" y="{y - 15:.0f}" width="160" height="30" rx="3" '
                   f'fill="{fill}" stroke="#2e7d32"/>')
        out.append(f'<text x="{x:.0f}" y="{y + 4:.0f}" text-anchor="middle">{escape(k)}</text>')
    out.append("</svg>")
    return GraphPicture("\n".join(out), nodes, topics, edges)
