"""Files written whole or not at all (the artifacts of failing tests)."""

from __future__ import annotations

from pathlib import Path

import pytest

from multicosim.core.files import replacing


def test_a_complete_write_replaces_the_file(tmp_path: Path) -> None:
    target = tmp_path / "deep" / "trace.mcap"
    with replacing(target) as temporary:
        temporary.write_bytes(b"whole")
    assert target.read_bytes() == b"whole"
    assert [p.name for p in target.parent.iterdir()] == ["trace.mcap"]


def _write_half(target: Path) -> None:
    with replacing(target) as temporary:
        temporary.write_bytes(b"half")
        raise OSError(28, "disk full")


def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path: Path) -> None:
    target = tmp_path / "trace.mcap"
    target.write_bytes(b"old")
    with pytest.raises(OSError, match="disk full"):
        _write_half(target)
    assert target.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["trace.mcap"]
