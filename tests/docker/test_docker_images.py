"""Image building: the mirror is read at run time, pins follow pyproject, builds are cached."""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

import pytest

import multicosim
from multicosim.docker import RUNTIME_IMAGE, build_images
from multicosim.docker._images import LABEL_INPUTS, _requirements, debian_mirror

ROOT = Path(__file__).resolve().parents[2]


def test_mirror_is_read_from_apt_sources(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("MCS_DEBIAN_MIRROR", raising=False)
    sources = tmp_path / "debian.sources"
    sources.write_text(
        "Types: deb\nURIs: http://mirror.example/debian\nSuites: bookworm bookworm-updates\n"
        "Components: main\n\n"
        "Types: deb\nURIs: http://mirror.example/debian-security\nSuites: bookworm-security\n"
    )
    assert debian_mirror(sources) == "http://mirror.example/debian"
    monkeypatch.setenv("MCS_DEBIAN_MIRROR", "http://other.example/debian")
    assert debian_mirror(sources) == "http://other.example/debian"


def test_runtime_requirements_are_the_pins_of_pyproject() -> None:
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())
    reqs = _requirements(pyproject, ["mujoco", "mavlink"])
    assert all("==" in r for r in reqs), reqs
    names = {r.split("==")[0] for r in reqs}
    assert {"msgspec", "pyzmq", "numpy", "mujoco", "pymavlink"} <= names
    assert not any(r.startswith("multicosim") for r in reqs)


def test_image_carries_the_pinned_versions(engine: Any, image: str) -> None:
    assert image == RUNTIME_IMAGE == f"multicosim/runtime:{multicosim.__version__}"
    script = (
        "import importlib.metadata as m;"
        "print(*[m.version(p) for p in ('multicosim','mujoco','pyzmq','msgspec','numpy',"
        "'pymavlink')])"
    )
    out = engine.containers.run(image, ["python", "-c", script], remove=True, init=True)
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())
    pins = dict(r.split("==") for r in _requirements(pyproject, ["mujoco", "mavlink"]))
    expected = [multicosim.__version__] + [
        pins[p] for p in ("mujoco", "pyzmq", "msgspec", "numpy", "pymavlink")
    ]
    assert out.decode().split() == expected


def test_build_is_skipped_when_nothing_changed(engine: Any, image: str) -> None:
    # Others may edit the source meanwhile (a real rebuild then): a few tries find a quiet gap.
    for _ in range(3):
        build_images()
        before = engine.api.inspect_image(image)
        assert build_images() == [image]
        after = engine.api.inspect_image(image)
        if after["Id"] == before["Id"]:
            break
    assert after["Id"] == before["Id"]
    assert after["Config"]["Labels"][LABEL_INPUTS]
