"""Campaigns and falsification from a notebook: ``simulate`` lives in a ``__main__`` without a file.

A real Jupyter kernel (ipykernel, driven by nbclient) runs a small notebook; its functions
reach the process pool's workers by value. ``python -`` is the same case from a terminal.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import nbformat
from nbclient import NotebookClient

SIMULATE = """
import multicosim as mcs
from multicosim import testing


def simulate(sample, fidelity, seed):
    simulator = mcs.ProcessSimulator(seed=seed)
    simulator.add(mcs.InProcessComponent(testing.Cart, name="cart"))
    node = simulator.add(mcs.InProcessFirmwareComponent(testing.drive))
    with simulator.start() as simulation:
        report = simulation.get(node).send(testing.Drive(speed=sample["speed"], steps=20))
    return {"time": report.times, "x": report.positions}
"""

CAMPAIGN = """
from multicosim.search.campaign import ProcessExecutor, run_campaign

# 20 steps of 0.05 s: the cart ends near speed * 0.95 m; beyond 2 m for speeds above ~2.1.
design = [{"speed": 0.5 * i} for i in range(1, 9)]
campaign = run_campaign(
    simulate, "always (x <= 2)", design, executor=ProcessExecutor(workers=2), progress=False
)
print(campaign.summary())
assert not campaign.failures and not campaign.retries, campaign.summary()
assert [r.status for r in campaign.results] == ["ok"] * 4 + ["violated"] * 4
"""

FALSIFY = """
from multicosim.search.falsify import falsify

result = falsify(
    simulate,
    "always (x <= 2)",
    {"speed": (0.5, 4.0)},
    optimizer="random",
    levels="low",
    budget=20,
    seed=1,
)
print(result.summary())
assert result.falsified
assert result.counterexample.example["speed"] > 2.0
"""


def test_a_notebook_runs_a_campaign_and_a_falsification(tmp_path: Path) -> None:
    notebook = nbformat.v4.new_notebook()  # type: ignore[no-untyped-call]
    notebook.cells = [
        nbformat.v4.new_code_cell(c)  # type: ignore[no-untyped-call]
        for c in (SIMULATE, CAMPAIGN, FALSIFY)
    ]
    client = NotebookClient(
        notebook,
        timeout=600,
        kernel_name="python3",
        resources={"metadata": {"path": str(tmp_path)}},
    )
    client.execute()  # raises CellExecutionError, with the cell's traceback, if one fails
    outputs = [
        "".join(o.get("text", "") for o in cell.outputs if o.output_type == "stream")
        for cell in notebook.cells
    ]
    assert "8 samples (4 ok, 4 violated), 0 retries" in outputs[1]
    assert "counterexample" in outputs[2]


def test_python_from_stdin_runs_a_campaign(tmp_path: Path) -> None:
    program = SIMULATE + CAMPAIGN
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    run = subprocess.run(
        [sys.executable, "-"],
        input=program,
        text=True,
        capture_output=True,
        cwd=tmp_path,
        env=env,
        timeout=600,
    )
    assert run.returncode == 0, run.stderr
    assert "8 samples (4 ok, 4 violated), 0 retries" in run.stdout
    assert "FileNotFoundError" not in run.stderr
