"""robocourse.pendulum: the ROS 2 pendulum demos (pendulum_control and the cart-pole demo).

``physics`` and ``pid`` reproduce the seed's PendulumMotor model and PendulumController;
``cartpole`` the newer demo's cart-pole with its LQR gain; ``analysis`` the python-control
view (transfer functions, margins, delay margin).
"""

from .cartpole import DEMO_K, CartPoleParams, lqr_gain
from .physics import PendulumPhysics, PendulumProperties, PendulumState
from .pid import SeedPID, TextbookPID

__all__ = ["DEMO_K", "CartPoleParams", "lqr_gain", "PendulumPhysics", "PendulumProperties", "PendulumState",
           "SeedPID", "TextbookPID"]
