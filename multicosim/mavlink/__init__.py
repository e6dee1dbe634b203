"""What every MAVLink autopilot shares, as MAVSDK's plugins are shared: PX4's and ArduPilot's
scenarios build on it, and it knows neither.

* ``dialect``: MAVLink's numbers (commands, frames, results, flags), links and frames;
* ``hil``: MAVLink's HIL messages (HIL_SENSOR, HIL_GPS, HIL_ACTUATOR_CONTROLS) as typed
  payloads on topics, and the world's ground truth;
* ``lockstep``: what a lockstep bridge to real firmware over a socket needs (the first
  client that speaks MAVLink, the errors of a firmware that went away or silent);
* ``mission``, ``gcs``, ``node``, [`trace`][multicosim.trace]: missions, the ground station
  that flies them over MAVLink (an autopilot's own procedure is a ``Procedure``),
  the firmware node it drives, and their traces;
* ``plan``, ``plan_link``, ``params``: QGroundControl plans (read, written, and
  flown item for item) and parameter files;
* ``udp``: MAVLink over UDP the way SITL firmware serves it.

PX4's modes, procedure and simulator interface are in [`multicosim.px4`][multicosim.px4],
ArduPilot's in [`multicosim.ardupilot`][multicosim.ardupilot]; the quadrotor both fly in
``multicosim.quadrotor``.
"""
