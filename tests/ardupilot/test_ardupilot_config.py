"""ArduPilot's configuration, frames and protocol pieces: refused before anything starts.

Nothing here runs ArduPilot; the bad directories are the ones a user could give.
"""

from __future__ import annotations

import dataclasses
import json
import math
import socket
from pathlib import Path
from typing import Any

import pytest
from ardupilot_helpers import fake_ardupilot

import multicosim as mcs
import multicosim.ardupilot as ardupilot
import multicosim.attacks as attacks
import multicosim.px4 as px4
from multicosim.ardupilot._bridge import MavlinkFramer, json_state
from multicosim.ardupilot._frames import (
    check_quad_x,
    copter_params,
    motor_outputs,
    rover_command,
    rover_params,
)
from multicosim.ardupilot.faults import FaultsConfig, SimulatedFaults
from multicosim.ardupilot.launch import SIM_PORT, claim_instance, launch_command
from multicosim.core.geo import Home, LocalProjection
from multicosim.mavlink.dialect import new_link
from multicosim.mavlink.hil import Truth
from multicosim.quadrotor.airframe import NONE_IRIS, Rotor

# -- the firmware directory ------------------------------------------------------------------


def test_a_firmware_is_needed() -> None:
    with pytest.raises(mcs.ConfigurationError, match="firmware_dir=None"):
        ardupilot.ArduCopter(fidelity="medium")


def test_a_missing_directory_is_refused(tmp_path: Path) -> None:
    with pytest.raises(mcs.ConfigurationError, match="an existing directory"):
        ardupilot.ArduCopter(firmware_dir=str(tmp_path / "nowhere"))


@pytest.mark.parametrize(
    ("cls", "binary"), [(ardupilot.ArduCopter, "arducopter"), (ardupilot.ArduRover, "ardurover")]
)
def test_a_directory_without_the_binary_is_refused(
    tmp_path: Path, cls: type[ardupilot.ArduCopter], binary: str
) -> None:
    fake_ardupilot(tmp_path)
    (tmp_path / "bin" / binary).unlink()
    with pytest.raises(mcs.ConfigurationError) as info:
        cls(firmware_dir=str(tmp_path))
    assert info.value.field == "firmware_dir"
    assert f"bin/{binary}" in str(info.value)
    assert "is missing" in str(info.value)


def test_a_binary_that_is_not_executable_is_refused(tmp_path: Path) -> None:
    fake_ardupilot(tmp_path)
    (tmp_path / "bin" / "arducopter").chmod(0o644)
    with pytest.raises(mcs.ConfigurationError, match="executable"):
        ardupilot.ArduCopter(firmware_dir=str(tmp_path))


def test_a_missing_parameter_file_is_refused(tmp_path: Path) -> None:
    fake_ardupilot(tmp_path)
    (tmp_path / "params" / "rover.parm").unlink()
    ardupilot.ArduCopter(firmware_dir=str(tmp_path))  # the copter's file is there
    with pytest.raises(mcs.ConfigurationError, match=r"params/rover.parm .*default parameters"):
        ardupilot.ArduRover(firmware_dir=str(tmp_path))


@pytest.mark.parametrize(
    ("params", "field"),
    [({"wpnav_speed": 5.0}, "params"), ({"WPNAV_SPEED": math.inf}, "params['WPNAV_SPEED']")],
)
def test_bad_parameters_are_refused(tmp_path: Path, params: dict[str, float], field: str) -> None:
    fake_ardupilot(tmp_path)
    with pytest.raises(mcs.ConfigurationError) as info:
        ardupilot.ArduCopter(firmware_dir=str(tmp_path), params=params)
    assert info.value.field == field


def test_there_is_no_low_fidelity_ardupilot(tmp_path: Path) -> None:
    fake_ardupilot(tmp_path)
    with pytest.raises(mcs.ConfigurationError, match=r"fidelity='low'.*MuJoCo"):
        ardupilot.ArduCopter(fidelity="low", firmware_dir=str(tmp_path))  # type: ignore[arg-type]


def test_the_world_step_must_divide_the_physics_frame(tmp_path: Path) -> None:
    fake_ardupilot(tmp_path)
    with pytest.raises(mcs.ConfigurationError, match=r"world.timestep=0.002.*2.5 ms"):
        ardupilot.ArduCopter(ardupilot.WorldConfig(timestep=0.002), firmware_dir=str(tmp_path))
    world = ardupilot.ArduCopter(
        ardupilot.WorldConfig(timestep=0.00125), firmware_dir=str(tmp_path)
    )
    assert world.world.period == pytest.approx(0.0025)


def test_an_image_runs_in_the_docker_placement_only() -> None:
    with pytest.raises(mcs.ConfigurationError, match="placement='docker'"):
        ardupilot.ArduCopter(image="multicosim/ardupilot-sitl:0.1.0")


def test_default_worlds_step_at_arducopters_loop_rate(tmp_path: Path) -> None:
    fake_ardupilot(tmp_path)
    for fidelity in ardupilot.FIRMWARE_FIDELITIES:
        simulator = ardupilot.ArduRover(fidelity=fidelity, firmware_dir=str(tmp_path))
        assert simulator.world.period == pytest.approx(1 / 400)
        assert simulator.world == dataclasses.replace(
            ardupilot.default_world("rover", fidelity), period=simulator.world.period
        )
    assert (
        ardupilot.default_world("copter", "high").timestep
        < ardupilot.default_world("copter", "medium").timestep
    )


# -- frames -------------------------------------------------------------------------------------


def test_none_iris_is_arducopters_quad_x_and_its_hover_is_computed() -> None:
    check_quad_x(NONE_IRIS)
    params = copter_params(NONE_IRIS)
    assert (params["FRAME_CLASS"], params["FRAME_TYPE"], params["MOT_THST_EXPO"]) == (1, 1, 0)
    # 1.5 kg on four 7 N rotors: 52.5 % motor command, in ArduCopter's 15-95 % spin range.
    assert params["MOT_THST_HOVER"] == pytest.approx((1.5 * 9.80665 / 28 - 0.15) / 0.8, abs=1e-3)


def test_an_airframe_in_another_motor_order_is_refused() -> None:
    r = NONE_IRIS.rotors
    swapped = dataclasses.replace(NONE_IRIS, rotors=(r[2], r[1], r[0], r[3]))
    with pytest.raises(mcs.ConfigurationError, match="quad X order"):
        check_quad_x(swapped)
    heavy = dataclasses.replace(NONE_IRIS, rotors=(*r[:3], Rotor(-0.15, 0.19, 0.05)))
    with pytest.raises(mcs.ConfigurationError):
        copter_params(heavy)


def test_pwm_maps_onto_motors_and_the_rovers_steering_and_throttle() -> None:
    assert motor_outputs([1000, 1500, 2000, 0, 1900], 4) == [0.0, 0.5, 1.0, 0.0]
    assert motor_outputs([900, 2100, 1000, 1000], 4) == [0.0, 1.0, 0.0, 0.0]
    # ArduRover: steering output above trim turns right (our steering: + is left).
    speed, steering = rover_command([2000, 0, 1750] + [0] * 13, 10.0, 0.5)
    assert speed == pytest.approx(5.0)
    assert steering == pytest.approx(-0.5)
    assert rover_command([0] * 16, 10.0, 0.5) == (0.0, 0.0)
    assert rover_params(10.0)["CRUISE_THROTTLE"] == 50.0


# -- the JSON protocol ------------------------------------------------------------------------


def test_the_json_answer_is_what_arducopters_parser_reads() -> None:
    t = Truth(1.0, 1.5, -2.0, -3.0, 0.1, 0.2, 0.3, 47.0, 8.0, 3.0, 1.0, 0.0, 0.0, 0.0,
              0.01, 0.02, 0.03, 0.0, 0.1, -9.8)  # fmt: skip
    line = json_state(12.5, t)
    assert line.startswith(b"\n{")
    assert line.endswith(b"}\n")
    assert b": " not in line  # no blank after a key's colon (sscanf "[%f, %f, %f]")
    state = json.loads(line)
    assert state["timestamp"] == 12.5
    assert state["imu"] == {"gyro": [0.01, 0.02, 0.03], "accel_body": [0.0, 0.1, -9.8]}
    assert state["position"] == [1.5, -2.0, -3.0]
    assert state["velocity"] == [0.1, 0.2, 0.3]
    assert state["quaternion"] == [1.0, 0.0, 0.0, 0.0]
    assert state["no_time_sync"] == 1


def test_the_framer_cuts_whole_mavlink_frames_from_a_stream() -> None:
    mav = new_link(1, 1, "ardupilotmega")
    frames = [bytes(mav.heartbeat_encode(2, 3, 0, i, 4).pack(mav)) for i in range(3)]
    stream = b"junk" + frames[0] + frames[1] + b"\x00\x01" + frames[2]
    framer = MavlinkFramer()
    out = framer.feed(stream[:7]) + framer.feed(stream[7:30]) + framer.feed(stream[30:])
    assert out == b"".join(frames)
    assert [m.custom_mode for m in new_link(0, 0).parse_buffer(out)] == [0, 1, 2]


def test_arducopter_listens_on_no_port() -> None:
    command = launch_command(
        "bin/arducopter", ["a.parm", "b.parm"], host="127.0.0.1", instance=3, home=Home(),
        mavlink_port=40000,
    )  # fmt: skip
    options = {key: command[i + 1] for i, key in enumerate(command) if key.startswith("--")}
    assert options["--serial0"] == "tcpclient:127.0.0.1:40000"
    assert options["--serial1"] == options["--serial2"] == "none"
    assert options["--rc-in-port"] == "0"
    assert options["--defaults"] == "a.parm,b.parm"
    assert "-I3" in command


def test_claimed_instances_skip_ports_in_use() -> None:
    first, held = claim_instance()
    try:
        # Another SITL's RC input port of the next instance: that instance is someone's.
        other = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        other.bind(("0.0.0.0", 5501 + 10 * (first + 1)))
        try:
            second, sock = claim_instance()
            sock.close()
        finally:
            other.close()
    finally:
        held.close()
    assert second not in (first, first + 1)
    assert second > first
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as again:
        again.bind(("127.0.0.1", SIM_PORT + 10 * first))  # released


def test_instances_are_claimed_from_the_first_one_given(tmp_path: Path) -> None:
    n, sock = claim_instance(first=7)
    sock.close()
    assert n >= 7
    # The last instance's physics port in use: no instance is left from there, and the
    # error names the ports.
    last, held = claim_instance(first=99)
    with held, pytest.raises(mcs.NodeStartError, match=r"no free ArduPilot instance: UDP ports"):
        claim_instance(first=99)
    assert last == 99
    directory = str(fake_ardupilot(tmp_path / "ap"))
    bads: tuple[Any, ...] = (-1, 100, 1.5, True)
    for bad in bads:
        with pytest.raises(mcs.ConfigurationError, match="first_instance"):
            ardupilot.SITL(directory=directory, first_instance=bad)
        with pytest.raises(mcs.ConfigurationError, match="first_instance"):
            px4.SITL(image="px4:tag", first_instance=bad)


# -- attacks as ArduPilot's simulated faults --------------------------------------------------


def test_faults_are_refused_where_arducopter_simulates_none() -> None:
    with pytest.raises(mcs.ConfigurationError, match="sensor='imu'"):
        FaultsConfig(sensor="imu", models=())
    with pytest.raises(mcs.ConfigurationError, match=r"models\[0\].on='velocity'"):
        FaultsConfig(sensor="gps", models=(attacks.Bias(offset=1.0, on="velocity"),))
    with pytest.raises(mcs.ConfigurationError, match=r"models\[0\].offset"):
        FaultsConfig(sensor="gps", models=(attacks.Bias(offset=(1.0, 2.0)),))


def test_gps_models_become_glitch_offsets_dropout_and_lag() -> None:
    home = Home()
    config = FaultsConfig(
        sensor="position",
        models=(
            attacks.Jump(offset=attacks.Local(north=10.0), start=10.0, ramp=2.0),
            attacks.Bias(offset=attacks.Local(east=3.0, up=-1.0), start=20.0, end=30.0),
            attacks.Dropout(start=40.0, end=50.0),
            attacks.Delay(delay=0.25, start=60.0),
        ),
        home=home,
    )
    assert config.sensor == "gps"
    faults = SimulatedFaults(config)
    rng = None
    assert faults.wanted(5.0, rng) == {
        "SIM_GPS_GLITCH_X": 0.0, "SIM_GPS_GLITCH_Y": 0.0, "SIM_GPS_GLITCH_Z": 0.0,
        "SIM_GPS_DISABLE": 0.0, "SIM_GPS_LAG_MS": 100.0,
    }  # fmt: skip
    proj = LocalProjection(home.lat, home.lon)
    half = faults.wanted(11.0, rng)  # half way up the ramp: 5 m north
    north, east = proj.project(
        home.lat + half["SIM_GPS_GLITCH_X"], home.lon + half["SIM_GPS_GLITCH_Y"]
    )
    assert north == pytest.approx(5.0, abs=1e-6)
    assert east == pytest.approx(0.0, abs=1e-9)
    both = faults.wanted(25.0, rng)  # 10 m north and 3 m east, 1 m down
    north, east = proj.project(
        home.lat + both["SIM_GPS_GLITCH_X"], home.lon + both["SIM_GPS_GLITCH_Y"]
    )
    assert north == pytest.approx(10.0, abs=1e-6)
    assert east == pytest.approx(3.0, abs=1e-6)
    assert both["SIM_GPS_GLITCH_Z"] == -1.0
    assert faults.wanted(45.0, rng)["SIM_GPS_DISABLE"] == 1.0
    assert faults.wanted(55.0, rng)["SIM_GPS_DISABLE"] == 0.0
    assert faults.wanted(65.0, rng)["SIM_GPS_LAG_MS"] == 350.0


def test_baro_models_become_its_glitch() -> None:
    faults = SimulatedFaults(
        FaultsConfig(sensor="barometer", models=(attacks.Bias(offset=4.0, start=1.0),))
    )
    assert faults.wanted(0.5, None) == {"SIM_BARO_GLITCH": 0.0}
    assert faults.wanted(2.0, None) == {"SIM_BARO_GLITCH": 4.0}
