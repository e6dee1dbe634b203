"""Ctrl-C stops a campaign: finished results are kept, no worker is left running."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

PROGRAM = textwrap.dedent(
    """
    import sys
    from multicosim.search.campaign import CampaignInterrupted, run_campaign
    import campaign_programs as programs

    pids, out = sys.argv[1], sys.argv[2]
    samples = [
        {"speed": 2.0, "distance": 2.0, "pids": pids, "slow": i >= 3} for i in range(8)
    ]
    done = []

    def finished(result):
        done.append(result)
        if len(done) == 3:
            print("three done", flush=True)

    try:
        run_campaign(programs.simulate_slowly, programs.REQUIREMENT, samples, output=out,
                     executor="process", progress=False, on_result=finished)
    except CampaignInterrupted as exc:
        print(f"interrupted with {len(exc.result.results)} results", flush=True)
        sys.exit(130)
    """
)


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def test_ctrl_c_keeps_finished_results_and_leaves_no_worker(tmp_path: Path) -> None:
    pids = tmp_path / "pids"
    pids.mkdir()
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).parent)}
    with subprocess.Popen(
        [sys.executable, "-c", PROGRAM, str(pids), str(tmp_path / "out")],
        stdout=subprocess.PIPE,
        text=True,
        env=env,
    ) as campaign:
        assert campaign.stdout is not None
        assert campaign.stdout.readline().strip() == "three done"
        # The slow samples are now running in the pool's workers.
        deadline = time.monotonic() + 30
        while len(list(pids.iterdir())) < 2 and time.monotonic() < deadline:
            time.sleep(0.05)
        campaign.send_signal(signal.SIGINT)
        out, _ = campaign.communicate(timeout=30)
    assert campaign.returncode == 130
    assert out.strip() == "interrupted with 3 results"
    rows = (tmp_path / "out" / "results.csv").read_text().strip().splitlines()
    assert len(rows) == 1 + 3  # the header and the three finished samples
    workers = [int(p.name) for p in pids.iterdir()]
    assert workers
    deadline = time.monotonic() + 10
    while any(_alive(pid) for pid in workers) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not [pid for pid in workers if _alive(pid)]
