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
        refs = c.reference_interfaces
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
