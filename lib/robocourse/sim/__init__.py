"""robocourse.sim: MuJoCo models of the course's plants and a fixed-step simulation loop."""

from . import models
from .simulation import Trace, run

__all__ = ["models", "run", "Trace"]
