"""A user's own process components import the user's modules wherever pytest was started."""

from __future__ import annotations

import sys

import pytest

CART_CTL = '''
import multicosim as mcs
from multicosim import testing


class Goto(mcs.Message):
    x: float


@mcs.firmware(msgtype=Goto, period=0.01)
def goto(target: Goto, ctx: mcs.FirmwareContext) -> float:
    """Drive the cart to ``target.x`` at 1 m/s; return where it stopped."""
    state = ctx.subscribe("state", testing.CartState)
    x = 0.0
    while x < target.x and ctx.time < 10.0:
        ctx.publish("cmd", testing.Speed(speed=1.0))
        ctx.step()
        if state.latest is not None:
            x = state.latest.x
    ctx.publish("cmd", testing.Speed(speed=0.0))
    return x
'''

TEST_CART = """
import pytest

import multicosim as mcs
from multicosim import testing

import cart_ctl


def test_goto_as_process(mcs_simulator):
    mcs_simulator.add(mcs.InProcessComponent(testing.Cart, name="cart"))
    node_id = mcs_simulator.add(
        mcs.ProcessFirmwareComponent(
            "python -m multicosim serve cart_ctl:goto --port {port}",
            msgtype=cart_ctl.Goto,
            replytype=float,
        )
    )
    simulation = mcs_simulator.start()
    assert simulation.get(node_id).send(cart_ctl.Goto(x=0.5)) == pytest.approx(0.5, abs=0.02)
"""


def test_process_component_imports_the_tests_modules_from_another_directory(
    pytester: pytest.Pytester, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytester.makepyfile(cart_ctl=CART_CTL, test_cart=TEST_CART)
    test_file = pytester.path / "test_cart.py"
    elsewhere = pytester.mkdir("elsewhere")
    # Started from another directory, with nothing on PYTHONPATH that finds cart_ctl: the
    # test imports it because pytest put the test's directory on sys.path.
    monkeypatch.delenv("PYTHONPATH", raising=False)
    monkeypatch.chdir(elsewhere)
    target = f"{test_file}::test_goto_as_process"
    result = pytester.run(sys.executable, "-m", "pytest", "-p", "no:cacheprovider", target)
    assert "No module named 'cart_ctl'" not in result.stdout.str()
    result.assert_outcomes(passed=1)
