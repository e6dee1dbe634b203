"""Make the documentation's pictures with the harness itself (docs/assets/pictures/).

Each picture is the plot a test of a page's listing keeps: the Getting started test made to
fail (its limit lowered to 20 m) and the fleet tutorial's crossing drones (kept with
``--mcs-keep-traces=all``). Flights take a few seconds each at low fidelity; the pictures are
committed, and this script makes them again after a change to the plots or the listings:
``.venv/bin/python scripts/pictures.py``.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PICTURES = ROOT / "docs" / "assets" / "pictures"
FENCE = re.compile(r"^```python\n(.*?)^```", re.M | re.S)

# picture: (page, a string of its listing, how the listing is changed, pytest's options, the
# test file's name as the page gives it)
SOURCES = {
    "failing-run.png": (
        "getting-started.md",
        "def test_the_mission_stays_below_30_m",
        ("true_alt <= 30", "true_alt <= 20"),
        ("--mcs-fidelity=low",),
        "test_drone.py",
    ),
    "fleet-crossing.png": (
        "tutorials/fleet.md",
        "def test_crossing_drones_lose_well_clear_but_never_touch",
        ("", ""),
        ("--mcs-fidelity=low", "--mcs-keep-traces=all"),
        "test_fleet.py",
    ),
}


def listing(page: str, containing: str) -> str:
    """The page's Python block that contains ``containing``."""
    text = (ROOT / "docs" / page).read_text()
    (block,) = [b for b in FENCE.findall(text) if containing in b]
    return str(block)


def make(name: str) -> Path:
    """Fly the picture's listing and keep its plot."""
    page, containing, (old, new), options, filename = SOURCES[name]
    with tempfile.TemporaryDirectory(prefix="mcs-pictures-") as tmp:
        test = Path(tmp) / filename
        test.write_text(listing(page, containing).replace(old, new))
        artifacts = Path(tmp) / "artifacts"
        subprocess.run(
            [sys.executable, "-m", "pytest", str(test), "-q", "-p", "no:cacheprovider",
             f"--mcs-artifacts={artifacts}", *options],
            cwd=tmp, check=False, capture_output=True, timeout=600,
        )  # fmt: skip
        plots = sorted(artifacts.rglob("*.png"))
        if not plots:
            raise SystemExit(f"{name}: the listing of {page} kept no plot")
        PICTURES.mkdir(parents=True, exist_ok=True)
        out = PICTURES / name
        shutil.copyfile(plots[0], out)
    return out


def main() -> int:
    for name in SOURCES:
        print(f"wrote {make(name).relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
