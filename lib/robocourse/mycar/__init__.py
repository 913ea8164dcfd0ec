"""robocourse.mycar: the "ROS2 MyCar" tutorial's car, from the motor driver up.

``kinematics``: the differential-drive model and odometry; ``drivers``: the MotorDriver
interface with a logging PWM stand-in and a MuJoCo-backed driver.
"""

from .drivers import MotorDriver, MujocoMotorDriver, SimulatedMotorDriver
from .kinematics import DiffDriveGeometry

__all__ = ["DiffDriveGeometry", "MotorDriver", "MujocoMotorDriver", "SimulatedMotorDriver"]
