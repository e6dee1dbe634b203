"""--mcs-ray and its ini twin select the executor that mcs_campaign_executor gives."""

from __future__ import annotations

import pytest

PROBE = """
def test_probe(mcs_campaign_executor, pytestconfig):
    executor = mcs_campaign_executor
    seen = f"{type(executor).__name__} {getattr(executor, 'address', None)}"
    (pytestconfig.rootpath / "seen.txt").write_text(seen)
"""


@pytest.mark.parametrize(
    ("args", "ini", "expected"),
    [
        ((), "", "ProcessExecutor None"),
        (("--mcs-ray=ray://head:10001",), "", "RayExecutor ray://head:10001"),
        ((), "mcs_ray = auto\n", "RayExecutor auto"),
        (("--mcs-ray=local",), "mcs_ray = auto\n", "RayExecutor local"),
    ],
)
def test_mcs_ray_selects_the_executor(
    pytester: pytest.Pytester, args: tuple[str, ...], ini: str, expected: str
) -> None:
    pytest.importorskip("ray", reason="ray is not installed (pip install 'multicosim[ray]')")
    pytester.makeini("[pytest]\n" + ini)
    pytester.makepyfile(test_probe=PROBE)
    # In a subprocess: numpy cannot be imported twice in one process. Nothing connects: the
    # executor reaches the cluster on first use only.
    pytester.runpytest_subprocess(*args).assert_outcomes(passed=1)
    assert (pytester.path / "seen.txt").read_text() == expected
