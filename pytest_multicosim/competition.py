"""The UAV Testing Competition's case files collected as tests, converted, and summed up.

A test generator of the competition writes its cases as YAML files in an output folder
([`multicosim.px4.competition`][multicosim.px4.competition] reads them). Named with
``--mcs-competition DIR`` (or the ``mcs_competition`` ini key), a folder's YAML files whose top
level holds ``drone:`` and ``simulation:`` are collected, each as a case of ours
([`cases`][pytest_multicosim.cases]) judged with ``score: competition``: one test named after the
file, parametrized over the fidelity levels, flown on the PX4 fixtures (real PX4 too where one is
configured), with the competition's distances, points and verdict as its properties. No other YAML
file is touched, and nothing is collected without the option.

The session's summary of their scores is ``scores``'s.

``to_mcs`` and ``from_mcs`` convert a case to our ``.mcs.yaml`` and back.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pytest

from multicosim.core.deps import require
from multicosim.core.errors import ConfigurationError

from .cases import Case, CaseFile, load_case
from .options import settings_key

__all__ = [
    "CompetitionFile",
    "from_case",
    "from_mcs",
    "is_competition_case",
    "to_case",
    "to_mcs",
]

SUFFIXES = (".yaml", ".yml")


def _within(path: Path, folders: tuple[Path, ...]) -> bool:
    return any(path.is_relative_to(folder) for folder in folders)


def is_competition_case(path: Path, config: pytest.Config) -> bool:
    """Whether ``path`` is a competition case to collect: a YAML file in a folder named by
    ``--mcs-competition`` whose top level holds ``drone:`` (or ``robot:``) and
    ``simulation:``."""
    folders = config.stash[settings_key].competition
    if not folders or path.suffix not in SUFFIXES or not _within(path.absolute(), folders):
        return False
    require("yaml", "cases")
    import msgspec

    try:
        data = msgspec.yaml.decode(path.read_bytes())
    except (OSError, msgspec.DecodeError):
        return False  # not YAML: another tool's file in the folder
    return (
        isinstance(data, dict) and bool({"drone", "robot"} & data.keys()) and "simulation" in data
    )


def _relative(file: Path, folder: Path) -> str:
    return os.path.relpath(file.absolute(), folder.absolute())


def to_case(path: Path, at: Path | None = None) -> Case:
    """The competition case in ``path`` as a case of ours, its files named relative to the
    folder of ``at`` (where the ``.mcs.yaml`` is to be; default: beside ``path``).

    Raises:
        ConfigurationError: what
        [`multicosim.px4.competition.read_case`][multicosim.px4.competition.read_case] raises.
    """
    from multicosim.px4.competition import read_case

    read = read_case(path)
    folder = (at or path).parent
    params: str | dict[str, float] | None = dict(read.params) if read.params else None
    if read.params_file is not None:
        params = _relative(read.params_file, folder)
    return Case(
        plan=_relative(read.mission_file, folder),
        params=params,
        obstacles=read.obstacles,
        time_limit=read.timeout,
        score="competition",
        description=f"the UAV test competition's case {path.name}",
    )


def from_case(case: Case, at: Path) -> Any:
    """A case of ours (its files relative to ``at``'s folder) as a competition case: a
    [`multicosim.px4.competition.CompetitionCase`][multicosim.px4.competition.CompetitionCase].

    Raises:
        ConfigurationError: for what the competition's format cannot say (ArduPilot, wind,
            requirements, obstacles placed by latitude and longitude).
    """
    from multicosim.px4.competition import CompetitionCase

    for field, value in (
        ("autopilot", case.autopilot if case.autopilot != "px4" else None),
        ("wind", case.wind),
        ("requirements", case.requirements or None),
    ):
        if value is not None:
            raise ConfigurationError(
                f"{at}: {field}", value, "none: the competition's cases fly PX4 in calm air"
            )
    params_file = at.parent / case.params if isinstance(case.params, str) else None
    from multicosim.mavlink.params import read_params

    params = dict(case.params) if isinstance(case.params, dict) else {}
    if params_file is not None:
        params = read_params(params_file)
    return CompetitionCase(
        mission_file=at.parent / case.plan,
        params=params,
        params_file=params_file,
        obstacles=case.obstacles,
        timeout=case.time_limit,
    )


def _encode(case: Case) -> bytes:
    """The case as ``.mcs.yaml`` text, without the fields left at their defaults."""
    import msgspec

    def clean(value: Any) -> Any:
        if isinstance(value, dict):
            return {k: clean(v) for k, v in value.items() if v not in (None, "", [], ())}
        if isinstance(value, list):
            return [clean(v) for v in value]
        return value

    data = clean(msgspec.to_builtins(case))
    if case.autopilot == "px4":
        data.pop("autopilot", None)
    return bytes(msgspec.yaml.encode(data))


def to_mcs(source: str | Path, dest: str | Path) -> Case:
    """Convert the competition case in ``source`` to our ``.mcs.yaml`` at ``dest``.

    The plan and the parameter file stay where they are (named relative to ``dest``); the
    obstacles become boxes in our frame; the verdict stays the competition's
    (``score: competition``). Returns the case written.
    """
    require("yaml", "cases")
    source, dest = Path(source), Path(dest)
    case = to_case(source, dest)
    dest.write_bytes(_encode(case))
    return case


def from_mcs(source: str | Path, dest: str | Path) -> None:
    """Convert our ``.mcs.yaml`` in ``source`` to a competition case at ``dest``.

    Raises:
        ConfigurationError: naming what the competition's format cannot say.
    """
    from multicosim.px4.competition import write_case

    source = Path(source)
    write_case(from_case(load_case(source), source), dest)


class CompetitionFile(CaseFile):
    """A competition case file collected as a module of one test (see
    [`CaseFile`][pytest_multicosim.competition.CaseFile])."""

    def load(self) -> Case:
        """The competition case in the file, as a case of ours scored as the competition does."""
        return to_case(self.path)
