"""robocourse.bridge: brain (policy) and cerebellum (servo loop) joined through a joint bridge.

- ``joint_bridge``: :class:`JointBridge` (the bridge article's RobotJointBridge: /joint_states,
  /joint_targets KEEP_LAST 1, dimension check, command timeout, safe mode hold or damping);
- ``realtime_thread``: :func:`configure_realtime_thread` (name, policy, mlockall, verified);
- ``deployment``: :class:`PolicyDeployment`, the CRISP deployment under ros2_control
  (50 Hz policy thread, 500 Hz ForwardCommandController, MujocoSystem), start-up sequence,
  exit damping, measured loop statistics, inference latency and observation -> command age.
"""

from .joint_bridge import DAMPING, HOLD, RUN, BridgeCommand, JointBridge
from .realtime_thread import (
    RealtimeThreadReport,
    configure_realtime_thread,
    release_realtime_thread,
    thread_name,
)

__all__ = ["DAMPING", "HOLD", "RUN", "BridgeCommand", "JointBridge", "PolicyDeployment", "RealtimeThreadReport",
           "configure_realtime_thread", "release_realtime_thread", "thread_name"]


def __getattr__(name):  # the deployment pulls in MuJoCo and the controller manager: import it on use
    if name == "PolicyDeployment":
        from .deployment import PolicyDeployment

        return PolicyDeployment
    raise AttributeError(name)
