"""cartpole.py: a cart-pole of one's own in multicosim's MuJoCo world, and its controller.

Component processes import it by name: ``cartpole:world`` runs the world (a participant),
``cartpole:balance`` the controller (a firmware).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import msgspec
import mujoco

import multicosim as mcs
import multicosim.attacks as attacks
from multicosim.physics import Physics, World, WorldConfig

PERIOD = 0.01  # s: the world publishes and the controller pushes at 100 Hz
STATE, PUSH = "cartpole/state", "cartpole/push"  # topics
TILT = 0.1  # rad: the pole's angle at the start (+: its top leans towards +x)
NOISE = (0.001, 0.01, 0.001, 0.01)  # the encoders' noise (m, m/s, rad, rad/s) at noise 1
GAINS = (10.0, 11.0, 65.0, 12.0)  # state feedback: LQR on MuJoCo's linearisation, rounded

MJCF = """
<mujoco model="cartpole">
  <worldbody>
    <body name="cart">
      <joint name="slider" type="slide" axis="1 0 0" damping="0.5"/>
      <geom type="box" size="0.2 0.1 0.05" mass="1" contype="0" conaffinity="0"/>
      <body name="pole">
        <joint name="hinge" type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.6" size="0.02" mass="0.1"
              contype="0" conaffinity="0"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor name="motor" joint="slider" ctrllimited="true" ctrlrange="-20 20"/>
  </actuator>
  <sensor>
    <jointpos joint="slider"/> <jointvel joint="slider"/>
    <jointpos joint="hinge"/> <jointvel joint="hinge"/>
  </sensor>
</mujoco>
"""


class State(mcs.Message):
    """The encoders: cart position (m) and velocity (m/s), pole angle (rad) and rate (rad/s)."""

    x: float
    v: float
    angle: float
    rate: float


class Push(mcs.Message):
    """The motor's force on the cart (N, + towards +x)."""

    force: float


class CartPole:
    """The cart-pole as the world's vehicle: a motor on the cart, encoders on both joints."""

    def __init__(self) -> None:
        # Each topic it publishes or reads, by name, with its default.
        self.sensors = {"state": STATE, "push": PUSH}

    def load_model(self) -> Any:
        """The MJCF above (a spec: the world adds its obstacles, or other vehicles, to it)."""
        return mujoco.MjSpec.from_string(MJCF)

    def setup(self, physics: Physics, ctx: mcs.StepContext, topics: Mapping[str, str]) -> None:
        """Subscribe to the motor's command; tilt the pole."""
        self.topic = topics["state"]  # where WorldConfig(sensor_topics=...) put it
        self.push = ctx.subscribe(topics["push"], Push)
        physics.qpos[1] = TILT

    def actuate(self, physics: Physics, ctx: mcs.StepContext) -> None:
        """Push with the latest command (MuJoCo holds it to the motor's range)."""
        if self.push.latest is not None:
            physics.ctrl[0] = self.push.latest.force

    def sense(self, physics: Physics, ctx: mcs.StepContext) -> None:
        """Publish the encoders' readings, with seeded noise scaled by WorldConfig.noise."""
        noise = ctx.rng.normal(0.0, NOISE) * physics.config.noise
        x, v, angle, rate = (physics.sensordata + noise).tolist()
        ctx.publish(self.topic, State(x=x, v=v, angle=angle, rate=rate))


def world(config: WorldConfig) -> World:
    """The world participant with the cart-pole in it."""
    return World(config, CartPole())


class Balance(mcs.Message):
    """Keep the pole up while the cart goes to ``target`` (m), for ``duration`` s."""

    target: float
    duration: float


def push(state: State, target: float) -> float:
    """The force that keeps the pole up and brings the cart to ``target``."""
    kx, kv, ka, kr = GAINS
    return kx * (state.x - target) + kv * state.v + ka * state.angle + kr * state.rate


@mcs.firmware(msgtype=Balance, period=PERIOD)
def balance(mission: Balance, ctx: mcs.FirmwareContext) -> State:
    """Balance on the encoders' readings; reply with the last reading."""
    state = ctx.subscribe(STATE, State)
    for _ in range(round(mission.duration / PERIOD)):
        ctx.step()
        if state.latest is not None:
            ctx.publish(PUSH, Push(force=push(state.latest, mission.target)))
    if state.latest is None:
        raise mcs.MulticosimError(f"nothing on {STATE}: is the cart-pole world running?")
    return state.latest


def offset(state: State, quantity: str, delta: Sequence[float]) -> State:
    """``state`` with ``delta`` added to one of its fields (how an injector corrupts it)."""
    return msgspec.structs.replace(state, **{quantity: getattr(state, quantity) + delta[0]})


QUANTITIES = {"angle": "rad", "rate": "rad/s", "x": "m", "v": "m/s"}  # "angle" by default
attacks.register(
    "cartpole",
    [
        attacks.Sensor(
            "cartpole",
            "state",
            State,
            {name: attacks.Quantity((name,), unit) for name, unit in QUANTITIES.items()},
            offset,
        )
    ],
)
