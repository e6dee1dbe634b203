"""Fixtures of the FMU tests: FMUs built to fail (``reference_fmus`` is the plugin's)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest
from fmu_helpers import faulty, statespace_fixed


@pytest.fixture(scope="session")
def faulty_fmu(
    reference_fmus: Path, tmp_path_factory: pytest.TempPathFactory
) -> Callable[[str], Path]:
    """``faulty_fmu(fault)``: Dahlquist rebuilt with ``fault`` (see ``fmu_helpers.FAULTS``),
    compiled once per session."""
    built: dict[str, Path] = {}

    def make(fault: str) -> Path:
        if fault not in built:
            built[fault] = faulty(reference_fmus, tmp_path_factory.mktemp(f"faulty-{fault}"), fault)
        return built[fault]

    return make


@pytest.fixture(scope="session")
def statespace(reference_fmus: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """StateSpace (FMI 3) rebuilt so that its structural parameters can be set."""
    return statespace_fixed(reference_fmus, tmp_path_factory.mktemp("statespace"))
