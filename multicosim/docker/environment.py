"""ContainerEnvironment: what a ContainerSimulator hands the components it starts.

Programs inside the containers reach the host's lockstep coordinator at the simulation
network's gateway address. Public because ``multicosim.mavlink`` recognises it (by this
module's name, without importing the Docker SDK) to start real firmware in a container.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from ..core.clock import Scheduler
from ..local.environment import LocalEnvironment
from ..local.waits import DEFAULT_STEP_TIMEOUT
from .engine import labels

__all__ = ["ContainerEnvironment"]


class ContainerEnvironment(LocalEnvironment):
    """What a ContainerSimulator hands its components: the network, the clock, the coordinator.

    The coordinator listens on the network's gateway address (never on all interfaces), so
    containers on the network, and only they and the host, can join the lockstep.
    """

    def __init__(
        self,
        *,
        run_id: str,
        run_dir: Path,
        seed: int,
        scheduler: Scheduler,
        client: Any,
        network: str,
        gateway: str,
        keep_logs: bool = False,
        step_timeout: float = DEFAULT_STEP_TIMEOUT,
    ) -> None:
        super().__init__(
            run_id=run_id,
            run_dir=run_dir,
            seed=seed,
            scheduler=scheduler,
            coordinator_host=gateway,
            step_timeout=step_timeout,
        )
        self.client = client
        self.network = network
        self.gateway = gateway
        self.keep_logs = keep_logs
        self.labels = labels(run_id)

    def container_name(self, name: str) -> str:
        """The Docker name of component ``name``'s container in this run."""
        return f"{self.run_id}-{re.sub(r'[^a-zA-Z0-9_.-]', '_', name)}"
