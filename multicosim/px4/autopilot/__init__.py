"""The built-in PX4-compatible autopilot: commander, navigator, estimator, control, MAVLink
streams, missions and parameters, measured against real PX4 v1.15.4.

``Autopilot`` is the participant that wires them together; it speaks PX4's
HIL messages to the world and MAVLink to ground stations, like PX4 SITL.
"""

from .firmware import Autopilot, AutopilotSpec

__all__ = ["Autopilot", "AutopilotSpec"]
