"""Teleop for MyCar: keys -> geometry_msgs/Twist on /cmd_vel (teleop_twist_keyboard's idea).

``KEYMAP`` is the shared mapping; ``TeleopNode.press(key)`` publishes; ``pad(node)`` is an
ipywidgets button pad for notebooks; ``run_terminal(node, ...)`` reads single keys from a
terminal (raw mode) or lines from a pipe.
"""

from __future__ import annotations

import sys

from robocourse.bus import Node
from robocourse.msgs.geometry_msgs import Twist

from .nodes import QOS_CMD_VEL

#: key -> (linear.x m/s, angular.z rad/s)
KEYMAP = {"w": (0.2, 0.0), "s": (-0.2, 0.0), "a": (0.0, 1.5), "d": (0.0, -1.5),
          "q": (0.2, 1.0), "e": (0.2, -1.0), "x": (0.0, 0.0), " ": (0.0, 0.0)}
HELP = "w forward, s back, a/d turn, q/e curve, x or space stop, Ctrl-C quit"


class TeleopNode(Node):
    def __init__(self, name: str = "teleop", **kwargs):
        super().__init__(name, **kwargs)
        self.pub = self.create_publisher(Twist, "/cmd_vel", QOS_CMD_VEL)
        self.sent: list[tuple[float, float]] = []

    def press(self, key: str) -> Twist:
        if key not in KEYMAP:
            raise ValueError(f"unknown teleop key {key!r}; keys: {HELP}")
        v, w = KEYMAP[key]
        msg = Twist()
        msg.linear.x, msg.angular.z = v, w
        self.pub.publish(msg)
        self.sent.append((v, w))
        return msg


def pad(node: TeleopNode):
    """An ipywidgets pad: one button per key (forward, left, stop, right, back)."""
    import ipywidgets as widgets

    def button(label, key):
        b = widgets.Button(description=label, layout=widgets.Layout(width="80px"))
        b.on_click(lambda _b: node.press(key))
        return b

    return widgets.VBox([
        widgets.HBox([button("curve L", "q"), button("forward", "w"), button("curve R", "e")]),
        widgets.HBox([button("left", "a"), button("stop", "x"), button("right", "d")]),
        widgets.HBox([button("back", "s")]),
    ])


def run_terminal(node: TeleopNode, stream=None, out=sys.stdout) -> int:
    """Publish one Twist per key until Ctrl-C / end of input; return how many were sent."""
    stream = stream or sys.stdin
    print(HELP, file=out, flush=True)
    if stream.isatty():
        import termios
        import tty

        fd = stream.fileno()
        old = termios.tcgetattr(fd)
        try:
            tty.setcbreak(fd)
            while True:
                ch = stream.read(1)
                if ch in ("\x03", "\x04", ""):
                    break
                if ch in KEYMAP:
                    v, w = node.press(ch).linear.x, node.sent[-1][1]
                    print(f"linear.x={v:+.2f} angular.z={w:+.2f}", file=out, flush=True)
        except KeyboardInterrupt:
            pass
        finally:
            termios.tcsetattr(fd, termios.TCSADRAIN, old)
    else:
        for line in stream:
            for ch in line.rstrip("\n"):
                if ch in KEYMAP:
                    node.press(ch)
    node.press("x")  # leave the car stopped
    return len(node.sent)
