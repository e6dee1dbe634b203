"""The fault-injection suite: each fault's detection time, and nothing left behind.

Every test here injects one fault into a running simulation, checks the error that reports
it, and records how long after the fault the error came (``fault_helpers.Detections``): that figure
goes to the test's JUnit properties and, with ``MCS_RECORD_FAULTS=1``, to
``bench/results/faults/FAULT.json`` (``python bench/faults.py --docs`` puts them in the
reliability table, docs/reliability.md). The only timed assertion is
the one the error owes: within the fault's own timeout plus ``fault_helpers.MARGIN``.
"""

from __future__ import annotations

import pytest
from fault_helpers import Detections


@pytest.fixture(autouse=True)
def _nothing_left(nothing_left: None) -> None:
    """No process, run directory, container or network outlives a test of the suite."""


@pytest.fixture
def detections(request: pytest.FixtureRequest) -> Detections:
    """Where a test records its fault's detection time."""
    return Detections(request)
