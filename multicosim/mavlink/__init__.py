"""What the MAVLink autopilots share: PX4 (real and built-in) and ArduPilot.

* :mod:`.dialect`: MAVLink's numbers (commands, frames, results, flags) and links;
* :mod:`.hil`: the HIL messages of PX4's simulator interface and the world's ground truth;
* :mod:`.hil_bridge`: the simulator side of PX4's ``simulator_mavlink`` (TCP 4560, lockstep),
  whose socket handling ArduPilot's JSON bridge reuses;
* :mod:`.sensors`, :mod:`.airframe`, :mod:`.quadrotor`: the none_iris quadrotor both autopilots
  fly in the MuJoCo world, with its HIL sensor suite;
* :mod:`.mission`, :mod:`.gcs`, :mod:`.node`, :mod:`.trace`: missions, the ground station that
  flies them over MAVLink, the firmware node it drives, and their traces;
* :mod:`.plan`, :mod:`.plan_link`, :mod:`.params`: QGroundControl plans (read, written, and
  flown item for item) and parameter files;
* :mod:`.sitl`: launching real SITL firmware as a process or a container.

Used by :mod:`multicosim.px4` and :mod:`multicosim.ardupilot`; it knows neither.
"""
