"""What this CI run left behind: component processes, containers and networks.

    python .ci/leaks.py snapshot FILE   before the tests: the resources that exist already
    python .ci/leaks.py check FILE      after them: exit 1, listing them, if any leaked

Scoped to this run, so that other jobs and users on the same machine and engine count for
nothing: a process counts if it carries both this run's ``MCS_CI_RUN`` marker (inherited
from ``.ci/run``) and a simulation's ``MCS_RUN_ID``; a container or network counts if it is
labelled by multicosim, did not exist at the snapshot, and its creating process has exited
(what a live session still uses is not a leak, and all of this run's sessions have ended).
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path


def _environ(pid: str) -> set[str]:
    try:
        return set(Path(f"/proc/{pid}/environ").read_bytes().decode(errors="replace").split("\0"))
    except OSError:  # gone, or another user's
        return set()


def processes(marker: str) -> list[str]:
    """Component processes started by this run that still exist."""
    found = []
    for pid in os.listdir("/proc"):
        if pid.isdigit() and int(pid) != os.getpid():
            env = _environ(pid)
            if f"MCS_CI_RUN={marker}" in env and any(e.startswith("MCS_RUN_ID=") for e in env):
                cmdline = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ")
                found.append(f"{pid} ({cmdline.decode(errors='replace').strip()})")
    return found


def docker_resources() -> tuple[dict[str, str], dict[str, str]]:
    """Labelled containers and networks: id -> owner label."""
    from multicosim.docker.engine import LABEL_OWNER, LABEL_RUN, client

    api = client().api
    containers = {
        c["Id"]: (c.get("Labels") or {}).get(LABEL_OWNER, "")
        for c in api.containers(all=True, filters={"label": LABEL_RUN})
    }
    networks = {
        n["Id"]: (n.get("Labels") or {}).get(LABEL_OWNER, "")
        for n in api.networks(filters={"label": LABEL_RUN})
    }
    return containers, networks


def main(argv: list[str]) -> int:
    command, path = argv
    containers, networks = docker_resources()
    if command == "snapshot":
        Path(path).write_text(json.dumps(sorted([*containers, *networks])))
        return 0
    from multicosim.docker.engine import owner_alive

    before = set(json.loads(Path(path).read_text()))

    def leaked(resources: dict[str, str]) -> list[str]:
        return [
            rid[:12]
            for rid, owner in resources.items()
            if rid not in before and owner_alive(owner) is False
        ]

    left = {
        "processes": processes(os.environ["MCS_CI_RUN"]),
        "containers": leaked(containers),
        "networks": leaked(networks),
    }
    if any(left.values()):
        print(f"leaked: {left}", file=sys.stderr)
        return 1
    print("nothing leaked")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
