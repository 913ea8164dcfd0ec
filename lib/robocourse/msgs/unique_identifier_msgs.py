"""unique_identifier_msgs/UUID (the goal id of actions)."""

from robocourse.msgs._core import message


@message("unique_identifier_msgs/msg/UUID", """
# A universally unique identifier (UUID).
uint8[16] uuid
""")
class UUID:
    """16 bytes as a list of ints (rclpy uses a numpy uint8 array)."""

    def hex(self) -> str:
        return "".join(f"{b:02x}" for b in self.uuid)


__all__ = ["UUID"]
