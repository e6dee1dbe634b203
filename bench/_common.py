"""Helpers shared by the benchmark scripts: the machine, results files, fits."""

from __future__ import annotations

import json
import math
import os
import platform
import sys
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
RESULTS = HERE / "results"
BENCHMARKS_PAGE = ROOT / "docs" / "benchmarks.md"  # the documentation's pages the figures go to
RELIABILITY_PAGE = ROOT / "docs" / "reliability.md"


def replace_section(page: Path, start: str, end: str, section: str) -> bool:
    """Put ``section`` (which begins with ``start`` and ends with ``end``) in ``page`` in
    place of what lies between those markers; False, and nothing written, if one is missing."""
    text = page.read_text()
    head, found_start, rest = text.partition(start)
    _, found_end, tail = rest.partition(end)
    if not found_start or not found_end:
        return False
    page.write_text(head + section + tail)
    return True


def cpu_model() -> str:
    """The CPU's model name (Linux), else what ``platform`` knows."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def os_name() -> str:
    """The distribution's pretty name (Linux), else ``platform.platform()``."""
    try:
        for line in Path("/etc/os-release").read_text().splitlines():
            if line.startswith("PRETTY_NAME="):
                return line.split("=", 1)[1].strip().strip('"')
    except OSError:
        pass
    return platform.platform(terse=True)


def machine() -> dict[str, Any]:
    """What the figures were measured on."""
    return {
        "cores": os.cpu_count(),
        "cpu": cpu_model(),
        "python": platform.python_version(),
        "os": os_name(),
        "kernel": platform.release(),
        "arch": platform.machine(),
        "load_average": round(os.getloadavg()[0], 2),
    }


def write_result(name: str, data: dict[str, Any], output: Path | None = None) -> Path:
    """Write ``data`` (with the machine) to ``bench/results/NAME.json`` or ``output``."""
    path = output or RESULTS / f"{name}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    data = {"benchmark": name, "machine": machine(), **data}
    path.write_text(json.dumps(data, indent=2) + "\n")
    return path


def fit_exponent(xs: list[float], ys: list[float]) -> float:
    """The least-squares slope of log(y) against log(x): cost ~ x**slope."""
    lx = [math.log(x) for x in xs]
    ly = [math.log(y) for y in ys]
    mx, my = sum(lx) / len(lx), sum(ly) / len(ly)
    sxx = sum((x - mx) ** 2 for x in lx)
    return sum((x - mx) * (y - my) for x, y in zip(lx, ly, strict=True)) / sxx


def fit_linear(xs: list[float], ys: list[float]) -> tuple[float, float]:
    """Least-squares ``y = a + b x``: (a, b)."""
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    b = sum((x - mx) * (y - my) for x, y in zip(xs, ys, strict=True)) / sum(
        (x - mx) ** 2 for x in xs
    )
    return my - b * mx, b


def python_env(*paths: Path) -> dict[str, str]:
    """Environment additions putting ``paths`` (default: the repository) on PYTHONPATH."""
    entries = [str(p) for p in (paths or (ROOT,))]
    if os.environ.get("PYTHONPATH"):
        entries.append(os.environ["PYTHONPATH"])
    return {"PYTHONPATH": os.pathsep.join(entries)}


def docker_reason() -> str | None:
    """None when a Docker engine answers and the runtime image exists, else why not."""
    try:
        from multicosim.docker import RUNTIME_IMAGE, engine_available
    except ImportError as exc:  # pragma: no cover - the docker extra is missing
        return f"the docker extra is not installed ({exc})"
    if engine_available() is not None:
        # The engine's own message names sockets and hosts: keep those out of the results.
        return "no Docker engine answers"
    from multicosim.docker.engine import client

    try:
        client().images.get(RUNTIME_IMAGE)
    except Exception:
        return f"image {RUNTIME_IMAGE} missing (multicosim images build)"
    return None


if __name__ == "__main__":  # pragma: no cover
    json.dump(machine(), sys.stdout, indent=2)


def time_steps(participant: Any) -> dict[str, float]:
    """Time ``participant``'s steps from now on: ``{"world_s": seconds}``, kept up to date."""
    spent = {"world_s": 0.0}
    step = participant.step

    def timed(ctx: Any) -> None:
        t = time.perf_counter()
        step(ctx)
        spent["world_s"] += time.perf_counter() - t

    participant.step = timed
    return spent
