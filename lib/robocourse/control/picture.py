"""A picture of the running system: hardware, interfaces, controllers, claims and chains, as SVG.

Counterpart: what ``ros2 control list_*`` prints and rqt_graph-like views of ros2_control,
drawn as one SVG that JupyterLab renders (``display(system_picture(cm))``) and a file can hold
(``.save("system.svg")``). Left: controllers in update order (preceding first), coloured by
state like ``ros2 control`` (active green, inactive cyan, unconfigured yellow), with their
exported reference interfaces. Right: hardware components with their command interfaces
(claimed blue, available white, unavailable grey) and a count of state interfaces.
Blue arrows: command claims (controller -> interface, including chained reference
interfaces); grey dashed arrows: state interfaces a controller reads (one arrow per component).
"""

from __future__ import annotations

from html import escape

STATE_FILL = {"active": "#b7e4b0", "inactive": "#b9e8f0", "unconfigured": "#f6e7a1", "finalized": "#f4b6b6",
              "unknown": "#dddddd"}
ROW = 18
WIDTH = 1000
CTRL_X, CTRL_W = 20, 390
HW_X, HW_W = 560, 420


class SystemPicture:
    """SVG text with a Jupyter repr; ``save(path)`` writes it."""

    def __init__(self, svg: str):
        self.svg = svg

    def _repr_svg_(self) -> str:
        return self.svg

    def __repr__(self) -> str:          # what a text-only view shows instead of the drawing
        import re

        size = re.search(r'width="(\d+)" height="(\d+)"', self.svg)
        return f"<picture: SVG {size.group(1)} x {size.group(2)} px>" if size else "<picture: SVG>"

    def save(self, path) -> None:
        with open(path, "w") as f:
            f.write(self.svg)


def _text(x, y, s, size=12, weight="normal", anchor="start", fill="#222"):
    return (f'<text x="{x}" y="{y}" font-family="monospace" font-size="{size}" font-weight="{weight}" '
            f'text-anchor="{anchor}" fill="{fill}">{escape(s)}</text>')


def _interface_row(parts, rm, key: str, x: float, y: float, width: float) -> None:
    """One command (or reference) interface: claimed blue, available white, unavailable grey."""
    claimed, avail = rm.command_interface_is_claimed(key), rm.command_interface_is_available(key)
    fill = "#7fb2f0" if claimed else ("#ffffff" if avail else "#bbbbbb")
    parts.append(f'<rect x="{x}" y="{y}" width="{width}" height="{ROW - 3}" fill="{fill}" stroke="#777"/>')
    owner = rm.claimed.get(key, "")
    parts.append(_text(x + 4, y + 12, key + (f"  <- {owner}" if claimed else ""), 11))


def system_picture(cm) -> SystemPicture:
    """Draw ``cm`` (a ControllerManager) as it is now."""
    rm = cm.rm
    parts: list[str] = []
    anchors: dict[str, tuple[float, float]] = {}    # interface key -> (x, y) of its row's edge
    comp_anchor: dict[str, tuple[float, float]] = {}
    y = 40
    for name, comp in rm.components.items():
        state = comp.wrapper.state.label
        h = 40 + ROW * (len(comp.command_keys) + 1) + 8
        parts.append(f'<rect x="{HW_X}" y="{y}" width="{HW_W}" height="{h}" rx="6" fill="{STATE_FILL[state]}" '
                     'stroke="#555"/>')
        parts.append(_text(HW_X + 8, y + 18, f"{name} [{state}]", 13, "bold"))
        parts.append(_text(HW_X + 8, y + 34, comp.info.hardware_plugin_name, 10, fill="#444"))
        ry = y + 40
        for key in comp.command_keys:
            _interface_row(parts, rm, key, HW_X + 8, ry, HW_W - 16)
            anchors[key] = (HW_X + 8, ry + ROW / 2 - 1)
            ry += ROW
        n_state = len(comp.state_keys)
        n_avail = sum(rm.state_interface_is_available(k) for k in comp.state_keys)
        parts.append(_text(HW_X + 12, ry + 12, f"{n_state} state interfaces ({n_avail} available)", 11,
                           fill="#333"))
        comp_anchor[name] = (HW_X + 8, ry + 8)
        y += h + 16
    hw_bottom = y
    y = 40
    ctrl_anchor: dict[str, tuple[float, float]] = {}
    for c in cm.list_controllers():
        refs = [f"{c.name}/{r}" for r in c.reference_interfaces]   # the service lists them without the prefix
        h = 30 + 16 + ROW * len(refs) + 6
        parts.append(f'<rect x="{CTRL_X}" y="{y}" width="{CTRL_W}" height="{h}" rx="6" '
                     f'fill="{STATE_FILL.get(c.state, "#ddd")}" stroke="#555"/>')
        parts.append(_text(CTRL_X + 8, y + 18, f"{c.name} [{c.state}]", 13, "bold"))
        parts.append(_text(CTRL_X + 8, y + 34, c.type + (f"  {c.update_rate} Hz" if c.update_rate else ""), 10,
                           fill="#444"))
        ry = y + 40
        for key in refs:
            _interface_row(parts, rm, key, CTRL_X + 8, ry, CTRL_W - 16)
            anchors[key] = (CTRL_X + CTRL_W - 8, ry + ROW / 2 - 1)
            ry += ROW
        ctrl_anchor[c.name] = (CTRL_X + CTRL_W, y + 18)
        y += h + 16
    # arrows: claims (blue) and state reads (grey dashed, one per component)
    for c in cm.list_controllers():
        sx, sy = ctrl_anchor[c.name]
        for key in c.claimed_interfaces:
            if key in anchors:
                tx, ty = anchors[key]
                if tx < sx:          # a chained reference interface on the left column: loop around
                    parts.append(f'<path d="M{sx},{sy} C{sx + 60},{sy} {tx + 60},{ty} {tx},{ty}" fill="none" '
                                 'stroke="#1f5fbf" stroke-width="1.6" marker-end="url(#arrow)"/>')
                else:
                    parts.append(f'<line x1="{sx}" y1="{sy}" x2="{tx}" y2="{ty}" stroke="#1f5fbf" '
                                 'stroke-width="1.6" marker-end="url(#arrow)"/>')
        if c.state == "active":
            reads = {rm.owner_of(k) for k in c.required_state_interfaces}
            for comp in sorted(reads & set(comp_anchor)):
                tx, ty = comp_anchor[comp]
                parts.append(f'<line x1="{tx}" y1="{ty}" x2="{sx}" y2="{sy + 6}" stroke="#888" stroke-dasharray="4 3" '
                             'marker-end="url(#arrow_grey)"/>')
    height = max(y, hw_bottom) + 20
    head = (f'<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{height}" '
            f'viewBox="0 0 {WIDTH} {height}">'
            '<defs><marker id="arrow" markerWidth="8" markerHeight="8" refX="7" refY="4" orient="auto">'
            '<path d="M0,0 L8,4 L0,8 z" fill="#1f5fbf"/></marker>'
            '<marker id="arrow_grey" markerWidth="8" markerHeight="8" refX="7" refY="4" orient="auto">'
            '<path d="M0,0 L8,4 L0,8 z" fill="#888"/></marker></defs>'
            f'<rect width="{WIDTH}" height="{height}" fill="white"/>'
            + _text(CTRL_X, 24, "controllers (update order)", 13, "bold")
            + _text(HW_X, 24, "hardware components", 13, "bold"))
    return SystemPicture(head + "".join(parts) + "</svg>")


# --- the lifecycle state machine, drawn from what a component went through ------------------------------------------

_LC_W, _LC_H = 150, 44
_LC_BOX = {"unknown": (20, 210, 110), "unconfigured": (200, 210, _LC_W), "inactive": (470, 210, _LC_W),
           "active": (740, 210, _LC_W), "finalized": (470, 400, _LC_W)}
#: every transition ros2_control drives (start, callback, goal): its arc (SVG path) and label (x, y, anchor)
_LC_EDGES = {
    ("unknown", "on_init", "unconfigured"): ("M130,232 L200,232", (150, 198, "middle")),
    ("unknown", "on_init", "finalized"): ("M75,254 Q110,420 470,424", (150, 380, "start")),
    ("unconfigured", "on_configure", "inactive"): ("M350,222 Q410,170 470,222", (410, 184, "middle")),
    ("inactive", "on_cleanup", "unconfigured"): ("M470,242 Q410,294 350,242", (410, 290, "middle")),
    ("inactive", "on_activate", "active"): ("M620,222 Q680,170 740,222", (680, 184, "middle")),
    ("active", "on_deactivate", "inactive"): ("M740,242 Q680,294 620,242", (680, 290, "middle")),
    ("inactive", "on_error", "unconfigured"): ("M500,210 Q410,110 320,210", (410, 136, "middle")),
    ("active", "on_error", "unconfigured"): ("M770,210 Q530,20 260,210", (530, 80, "middle")),
    ("unconfigured", "on_shutdown", "finalized"): ("M275,254 Q300,410 470,414", (300, 350, "start")),
    ("inactive", "on_shutdown", "finalized"): ("M520,254 L520,400", (514, 340, "end")),
    ("inactive", "on_error", "finalized"): ("M570,254 L570,400", (576, 340, "start")),
    ("active", "on_shutdown", "finalized"): ("M790,254 Q780,400 620,410", (700, 380, "start")),
    ("active", "on_error", "finalized"): ("M850,254 Q850,440 620,430", (790, 455, "start")),
}


def lifecycle_picture(history, title: str = "") -> SystemPicture:
    """The managed-node state machine with the transitions ``history`` went through drawn bold.

    ``history``: a :class:`~robocourse.control.lifecycle.Transition` list (``component.wrapper.history``,
    or several concatenated). Every transition ros2_control drives is drawn (grey dashed when this
    run never took it); a taken one is blue with the callback, its results and how often; a
    callback that returned FAILURE (the state stays) is a red loop on its state. Counterpart: the
    diagram of the ROS 2 design article "Managed nodes", restricted to the primary states
    ros2_control uses.
    """
    from collections import Counter

    taken = Counter((t.start, t.callback, t.goal, t.result) for t in history)
    parts: list[str] = []
    for (start, cb, goal), (path, (lx, ly, anchor)) in _LC_EDGES.items():
        hits = {res: n for (s, c, g, res), n in taken.items() if (s, c, g) == (start, cb, goal)}
        colour, width, dash = ("#1f5fbf", 2.4, "") if hits else ("#c8c8c8", 1.2, ' stroke-dasharray="5 4"')
        parts.append(f'<path d="{path}" fill="none" stroke="{colour}" stroke-width="{width}"{dash} '
                     f'marker-end="url(#{"lc_blue" if hits else "lc_grey"})"/>')
        label = cb + ("" if not hits else " " + ", ".join(f"{r} x{n}" for r, n in sorted(hits.items())))
        parts.append(_text(lx, ly, label, 11, "bold" if hits else "normal", anchor, "#1f5fbf" if hits else "#9a9a9a"))
    loops = Counter((t.start, t.callback, t.result) for t in history if t.start == t.goal and t.callback != "on_error")
    stacked: Counter = Counter()
    for (state, cb, res), n in sorted(loops.items()):
        x, y, w = _LC_BOX[state]
        k = stacked[state]
        stacked[state] += 1
        cx = x + w - 40
        parts.append(f'<path d="M{cx - 18},{y + _LC_H} C{cx - 28},{y + _LC_H + 40} {cx + 28},{y + _LC_H + 40} '
                     f'{cx + 18},{y + _LC_H}" fill="none" stroke="#c0392b" stroke-width="2" marker-end="url(#lc_red)"/>')
        parts.append(_text(cx, y + _LC_H + 50 + 14 * k, f"{cb} {res} x{n} (stays)", 11, "bold", "middle", "#c0392b"))
    visited = {t.goal for t in history} | {t.start for t in history}
    for state, (x, y, w) in _LC_BOX.items():
        fill = STATE_FILL.get(state, "#ddd") if state in visited else "#f4f4f4"
        parts.append(f'<rect x="{x}" y="{y}" width="{w}" height="{_LC_H}" rx="8" fill="{fill}" stroke="#555"/>')
        parts.append(_text(x + w / 2, y + 27, state.upper(), 13, "bold", "middle"))
    width, height = 920, 470
    head = (f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}">'
            '<defs>' + "".join(
                f'<marker id="lc_{n}" markerWidth="8" markerHeight="8" refX="7" refY="4" orient="auto">'
                f'<path d="M0,0 L8,4 L0,8 z" fill="{c}"/></marker>'
                for n, c in (("blue", "#1f5fbf"), ("grey", "#c8c8c8"), ("red", "#c0392b")))
            + f'</defs><rect width="{width}" height="{height}" fill="white"/>'
            + _text(20, 24, title or "lifecycle: transitions this run took (blue, with results and counts), "
                                     "never taken (grey)", 13, "bold"))
    return SystemPicture(head + "".join(parts) + "</svg>")
