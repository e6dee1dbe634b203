"""The Ray backend: components as Ray actors on a cluster's nodes (the ``ray`` placement).

Needs the ``ray`` extra (``pip install 'multicosim[ray]'``), multicosim installed on every
node, and this process running on a node of the cluster (its nodes reach the simulation's
coordinator here). Ray is imported when a simulation joins the cluster (or the placement is
prepared), not when this package or the placement's name is.

* [`placement`][multicosim.placement]: [`Ray`][multicosim.ray.Ray], the placement, and the
  components it makes;
* ``simulator``: [`RaySimulator`][multicosim.ray.RaySimulator] and what it hands its components;
* ``node``: the nodes of components on the cluster, watched through their actors;
* ``host``: the actor that runs a component's program on its node;
* ``cluster``: joining the cluster;
* ``localcluster``: [`LocalCluster`][multicosim.ray.LocalCluster], a cluster of several nodes on
  this machine.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..core.deps import lazy_exports

_LAZY = {
    "ENV_ADDRESS": ".cluster",
    "ComponentHost": ".host",
    "LocalCluster": ".localcluster",
    "Ray": ".placement",
    "RayEnvironment": ".simulator",
    "RayFirmware": ".placement",
    "RayFirmwareNode": ".node",
    "RayNode": ".node",
    "RayParticipant": ".placement",
    "RaySimulation": ".simulator",
    "RaySimulator": ".simulator",
}
__all__ = [
    "ENV_ADDRESS",
    "ComponentHost",
    "LocalCluster",
    "Ray",
    "RayEnvironment",
    "RayFirmware",
    "RayFirmwareNode",
    "RayNode",
    "RayParticipant",
    "RaySimulation",
    "RaySimulator",
]

if TYPE_CHECKING:
    from .cluster import ENV_ADDRESS
    from .host import ComponentHost
    from .localcluster import LocalCluster
    from .node import RayFirmwareNode, RayNode
    from .placement import Ray, RayFirmware, RayParticipant
    from .simulator import RayEnvironment, RaySimulation, RaySimulator

__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
