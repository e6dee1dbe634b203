"""The soak: suites run again and again on an oversubscribed machine; verdicts and samples counted.

    python bench/soak.py            # the scenario suites and PX4's conformance suites, 5 runs each
    python bench/soak.py --docs     # ... and the table on docs/reliability.md
    python bench/soak.py --only scenarios-low --merge   # one suite again, keep the others'
    python bench/soak.py --smoke    # one suite, 2 runs (CI: does the soak still run?)

Each suite runs as pytest does for a user, with ``--mcs-repeat=RUNS --mcs-repeat-load``: every
test of ours RUNS times with one seed, each from a clean slate, beside twice as many busy
processes as the machine has cores (the plugin starts them). A test whose verdict changes, or
whose samples change on a built-in autopilot, fails there, naming where; real PX4 and ArduPilot
(their own threads) are held to their verdict only, and where their runs first parted is
counted. The counts come from the JUnit report's ``mcs_repeat`` properties; the figures go to
``bench/results/soak.json`` (``--output``) and, with ``--docs``, to the reliability page
(between ``<!-- soak:start -->`` and ``<!-- soak:end -->``).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import threading
import time
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

from _common import RELIABILITY_PAGE, RESULTS, ROOT, machine, replace_section

START, END = "<!-- soak:start -->", "<!-- soak:end -->"

# (key, name, pytest arguments): the scenario suites at every level the README's commands run,
# and PX4's conformance suites (our answers against real PX4's, PX4's own MAVSDK cases). Real
# PX4 and ArduPilot fly in them where they are configured (MCS_PX4_BINARY, MCS_ARDUPILOT_DIR).
SUITES = (
    ("scenarios-low", "scenario suites, low", ("scenarios", "--mcs-fidelity=low")),
    ("scenarios-medium", "scenario suites, medium", ("scenarios", "--mcs-fidelity=medium")),
    (
        "conformance",
        "PX4 conformance suites, medium",
        ("tests/px4/test_conformance.py", "tests/px4/test_px4_suite.py", "--mcs-fidelity=medium"),
    ),
)
SMOKE = (("rover", "rover scenarios, low", ("scenarios/test_rover.py", "--mcs-fidelity=low")),)
# The environment that makes the suites fly real firmware, and which firmware it is.
FIRMWARE_ENV = {"MCS_PX4_BINARY": "PX4", "MCS_PX4_IMAGE": "PX4", "MCS_ARDUPILOT_DIR": "ArduPilot"}


def run_suite(key: str, name: str, args: tuple[str, ...], runs: int, load: int) -> dict[str, Any]:
    """Run one suite repeated under load; what its JUnit report says, counted."""
    with tempfile.TemporaryDirectory(prefix="mcs-soak-") as tmp:
        report = Path(tmp) / "junit.xml"
        cmd = [
            sys.executable, "-m", "pytest", *args, f"--mcs-repeat={runs}",
            f"--mcs-repeat-load={load}", f"--junitxml={report}",
            f"--mcs-artifacts={Path(tmp) / 'artifacts'}", "-q", "-p", "no:cacheprovider",
        ]  # fmt: skip
        loads: list[float] = []
        done = threading.Event()

        def sample() -> None:  # the load the suite ran under, every 5 s
            while not done.wait(5.0):
                loads.append(os.getloadavg()[0])

        sampler = threading.Thread(target=sample, daemon=True)
        sampler.start()
        t0 = time.perf_counter()
        result = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        done.set()
        sampler.join()
        if not report.exists():
            tail = (result.stderr or result.stdout).strip().splitlines()[-5:]
            raise SystemExit(f"{name}: no report ({' / '.join(tail)})")
        counts = count(report)
    summary = next((line for line in result.stdout.splitlines() if "proven repeatable" in line), "")
    return {
        "key": key,
        "suite": name,
        "real_firmware": sorted(v for v in FIRMWARE_ENV if os.environ.get(v)),
        "command": "pytest " + " ".join(args) + f" --mcs-repeat={runs} --mcs-repeat-load={load}",
        "runs": runs,
        "busy_processes": load,
        "load_average": {
            "min": round(min(loads), 2) if loads else None,
            "max": round(max(loads), 2) if loads else None,
        },
        "wall_s": round(wall, 1),
        "exit_code": result.returncode,
        "summary": summary,
        **counts,
    }


def count(report: Path) -> dict[str, Any]:
    """Tests, verdict changes and sample changes in a JUnit report of a repeated run."""
    tests = proven = verdict_only = no_samples = skipped = 0
    verdict_changes: list[str] = []
    sample_changes: list[str] = []
    other_failures: list[str] = []
    parted: list[str] = []
    for case in ET.parse(report).iter("testcase"):
        test = f"{case.get('classname')}::{case.get('name')}"
        props = {p.get("name"): p.get("value") or "" for p in case.iter("property")}
        state = props.get("mcs_repeat")
        failure = case.find("failure")
        if case.find("skipped") is not None and failure is None:
            skipped += 1
            continue
        tests += 1
        message = failure.get("message", "") if failure is not None else ""
        if "not repeatable" in message:
            (sample_changes if "routed other samples" in message else verdict_changes).append(test)
        elif failure is not None or case.find("error") is not None:
            other_failures.append(test)  # the same failure in every run: repeatable
        if state is None:
            continue
        if state.startswith("same verdict"):
            verdict_only += 1
            if "first differ" in state:
                parted.append(f"{test}: {state}")
        elif "no samples" in state:
            no_samples += 1
        elif state.startswith("repeatable"):
            proven += 1
    return {
        "tests": tests,
        "skipped": skipped,
        "proven_repeatable": proven,
        "real_firmware_same_verdict": verdict_only,
        "no_samples_same_verdict": no_samples,
        "verdict_changes": verdict_changes,
        "sample_changes": sample_changes,
        "failed_every_run": other_failures,
        "real_firmware_parted": parted,
    }


# Where a repeat's report says two runs of real firmware first parted (the values are left out).
PARTED = re.compile(r"samples first differ at t=([0-9.e+-]+) s, topic '([^']+)'")


def table(results: dict[str, Any]) -> str:
    """The reliability page's section."""
    host = results["machine"]
    lines = [
        START,
        f"Generated by `python bench/soak.py --docs` on {host['cores']} cores ({host['cpu']}): "
        "each suite run as a user runs it with `--mcs-repeat=N --mcs-repeat-load`, every test "
        "N times with one seed beside twice as many busy processes as cores. A sample change "
        "is any routed message that differs in any bit; real PX4 and ArduPilot are held to "
        "their verdicts only.",
        "",
        "| suite | tests x runs | load average | verdict changes | sample changes (built-in) "
        "| proven repeatable | real firmware, same verdict | wall |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for s in results["suites"]:
        load = s["load_average"]
        real = sorted({FIRMWARE_ENV[v] for v in s.get("real_firmware", ())})
        name = s["suite"] + (f" (real {' and '.join(real)} too)" if real else "")
        loads = f"{load['min']:g} to {load['max']:g}" if load["min"] is not None else "-"
        lines.append(
            f"| {name} | {s['tests']} x {s['runs']} | {loads} "
            f"| {len(s['verdict_changes'])} | {len(s['sample_changes'])} "
            f"| {s['proven_repeatable']} | {s['real_firmware_same_verdict']} "
            f"| {s['wall_s'] / 60:.0f} min |"
        )
    parted = [p for s in results["suites"] for p in s["real_firmware_parted"]]
    if parted:
        lines += [
            "",
            "Where real firmware's runs of one seed first parted (PX4's and ArduPilot's own "
            "threads; their verdicts did not change):",
            "",
        ]
        for p in parted:
            test, _, text = p.partition(": ")
            where = PARTED.search(text)
            said = f"first parted at t={where[1]} s, on `{where[2]}`" if where else text
            lines.append(f"* `{test}`: {said}")
    lines.append(END)
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5, help="runs of every test (default 5)")
    parser.add_argument("--smoke", action="store_true", help="one suite, 2 runs; writes nothing")
    parser.add_argument("--docs", action="store_true", help="write the reliability page's table")
    parser.add_argument("--output", type=Path, default=RESULTS / "soak.json")
    parser.add_argument("--only", default="", help="suites to run, by key (comma list)")
    parser.add_argument(
        "--merge", action="store_true", help="keep the other suites' figures from --output"
    )
    args = parser.parse_args()
    load = 2 * (os.cpu_count() or 1)
    suites = SMOKE if args.smoke else SUITES
    if args.only:
        wanted = args.only.split(",")
        unknown = set(wanted) - {key for key, _, _ in SUITES}
        if unknown:
            parser.error(
                f"--only: unknown suite(s) {sorted(unknown)}; allowed: "
                f"{', '.join(key for key, _, _ in SUITES)}"
            )
        suites = tuple(s for s in SUITES if s[0] in wanted)
    runs = 2 if args.smoke else args.runs
    results: dict[str, Any] = {"machine": machine(), "suites": []}
    if args.merge and args.output.exists():
        results["suites"] = json.loads(args.output.read_text())["suites"]
    order = [key for key, _, _ in SUITES]
    for key, name, suite_args in suites:
        found = run_suite(key, name, suite_args, runs, load)
        results["suites"] = sorted(
            [s for s in results["suites"] if s.get("key") != key] + [found],
            key=lambda s: order.index(s["key"]) if s.get("key") in order else len(order),
        )
        if not args.smoke:  # each suite's figures as soon as it is done
            args.output.parent.mkdir(parents=True, exist_ok=True)
            args.output.write_text(json.dumps(results, indent=2) + "\n")
        changes = len(found["verdict_changes"]) + len(found["sample_changes"])
        print(
            f"{name}: {found['tests']} tests x {runs} runs, {changes} changes; {found['summary']}"
        )
    bad = [t for s in results["suites"] for t in s["verdict_changes"] + s["sample_changes"]]
    if args.smoke:
        if bad:
            raise SystemExit(f"not repeatable: {', '.join(bad)}")
        return
    section = table(results)
    print(section)
    if args.docs and not replace_section(RELIABILITY_PAGE, START, END, section):
        raise SystemExit(f"{RELIABILITY_PAGE} has no {START} ... {END} section")


if __name__ == "__main__":
    main()
