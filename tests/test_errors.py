"""The exception tree: one root, every public error exported by the package, libraries mapped."""

from __future__ import annotations

import inspect
import pickle
import re

import pytest
import zmq

import multicosim as mcs
from multicosim.core import errors as _errors
from multicosim.search.requirements import Requirement


def _public_exceptions() -> dict[str, type[BaseException]]:
    # The core's errors, and the three that live beside what they carry.
    return {
        name: value
        for name in mcs.__all__
        if inspect.isclass(value := getattr(mcs, name)) and issubclass(value, BaseException)
    }


def test_the_core_defines_every_error_but_those_beside_their_payload() -> None:
    beside = {"CampaignInterrupted", "ComponentCheckError", "RequirementViolation"}
    core = {n for n in _errors.__all__ if inspect.isclass(getattr(_errors, n))}
    assert core == set(_public_exceptions()) - beside


def test_every_public_error_is_a_multicosim_error_exported_from_the_package() -> None:
    errors = _public_exceptions()
    assert len(errors) >= 18
    for name, cls in errors.items():
        assert issubclass(cls, mcs.MulticosimError), name
        assert getattr(mcs, name) is cls, name


def test_the_documented_tree_names_every_error_once() -> None:
    doc = _errors.__doc__ or ""
    (tree,) = re.findall(r"^```text\n(.*?)^```", doc, re.M | re.S)
    drawn = re.findall(r"^(?:[│ ]*[├└]── )?([A-Z]\w+)", tree, re.M)
    assert sorted(drawn) == sorted(_public_exceptions())


def test_errors_defined_elsewhere_are_the_same_classes() -> None:
    import multicosim.docker
    import multicosim.physics
    import multicosim.search.campaign
    import multicosim.search.requirements

    assert multicosim.search.requirements.FormulaError is mcs.FormulaError
    assert multicosim.search.requirements.RequirementViolation is mcs.RequirementViolation
    assert multicosim.physics.PhysicsDivergedError is mcs.PhysicsDivergedError
    assert multicosim.docker.EngineUnavailableError is mcs.EngineUnavailableError
    assert multicosim.docker.ImageMissingError is mcs.ImageMissingError
    assert multicosim.search.campaign.CampaignInterrupted is mcs.CampaignInterrupted


def test_classic_bases_are_kept() -> None:
    assert issubclass(mcs.CampaignInterrupted, KeyboardInterrupt)
    assert issubclass(mcs.RequirementViolation, AssertionError)
    assert issubclass(mcs.FormulaError, ValueError)
    assert issubclass(mcs.ImageMissingError, mcs.NodeStartError)


@pytest.mark.parametrize(
    "error",
    [
        mcs.ConfigurationError("speed", -1.0, "a speed > 0"),
        mcs.FormulaError("always (x <", 1, 11, "unexpected end"),
        _errors.DependencyMissingError("torch", "gp"),
        mcs.NodeCrashedError("world", "exited", exit_code=3, log_tail="boom\n"),
        mcs.RemoteError("autopilot", "KeyError", "'x'", "Traceback ..."),
        mcs.RequirementViolation(
            Requirement("always (x >= 0)").evaluate({"time": [0.0], "x": [-1.0]})
        ),
    ],
    ids=lambda e: type(e).__name__,
)
def test_errors_cross_process_boundaries(error: mcs.MulticosimError) -> None:
    # Campaign workers and Ray send errors back pickled; custom constructors must not break it.
    back = pickle.loads(pickle.dumps(error))
    assert type(back) is type(error)
    assert str(back) == str(error)
    assert vars(back).keys() == vars(error).keys()
    if isinstance(error, mcs.RequirementViolation):
        assert isinstance(back, mcs.RequirementViolation)
        assert back.evaluation.robustness == error.evaluation.robustness == -1.0
    else:
        assert vars(back) == vars(error)
    if isinstance(error, mcs.NodeError):
        assert isinstance(back, mcs.NodeError)
        assert (back.name, back.exit_code, back.log_tail) == ("world", 3, "boom\n")


def test_a_zeromq_error_becomes_a_transport_error_naming_the_endpoint() -> None:
    context = zmq.Context()
    first, second = context.socket(zmq.ROUTER), context.socket(zmq.ROUTER)
    try:
        port = first.bind_to_random_port("tcp://127.0.0.1")
        with pytest.raises(zmq.ZMQError) as caught:
            second.bind(f"tcp://127.0.0.1:{port}")
        error = _errors.translate(caught.value, name="probe")
        assert isinstance(error, mcs.TransportError)
        assert str(error).startswith("probe: ZeroMQ: ")
    finally:
        first.close(0)
        second.close(0)
        context.term()


def test_a_taken_firmware_port_is_a_transport_error() -> None:
    import threading

    from multicosim import testing

    context = zmq.Context()
    holder = context.socket(zmq.ROUTER)
    try:
        port = holder.bind_to_random_port("tcp://127.0.0.1")
        with pytest.raises(mcs.TransportError, match=f"tcp://127.0.0.1:{port}"):
            mcs.serve(
                testing.echo,
                port=port,
                host="127.0.0.1",
                stop=threading.Event(),
                environment=(None, "echo", 0),
            )
    finally:
        holder.close(0)
        context.term()


def test_an_rtamt_parse_error_becomes_a_formula_error_with_its_place() -> None:
    with pytest.raises(mcs.FormulaError) as caught:
        Requirement("always (alt >= 0) and", semantics="dense").evaluate(
            {"time": [0.0, 1.0], "alt": [1.0, 2.0]}
        )
    assert caught.value.field == "formula"
    assert "column" in str(caught.value)


def test_library_errors_of_unknown_origin_are_not_translated() -> None:
    assert _errors.translate(OSError("disk full")) is None
    error = mcs.TraceError("x")
    assert _errors.translate(error) is error
