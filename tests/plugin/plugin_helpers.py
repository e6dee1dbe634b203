"""Helpers shared by the plugin tests."""

from __future__ import annotations

from pathlib import Path

import pytest

# The inner runs use the project's strictness, so a warning raised by the plugin fails them.
INNER_INI = """\
[pytest]
addopts = --strict-markers -p no:cacheprovider
filterwarnings = error
{extra}
"""


def write_ini(pytester: pytest.Pytester, **values: str) -> Path:
    """Write the inner run's pytest.ini with ``values`` as extra ini options."""
    extra = "\n".join(f"{key} = {value}" for key, value in values.items())
    return pytester.makefile(".ini", pytest=INNER_INI.format(extra=extra))
