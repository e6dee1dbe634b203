"""The package's shape: no import cycle, no package reaching into another's private parts,
no file over 600 lines (``lint-imports`` checks the layers themselves, in CI).

Every import counts: at module level, inside functions and under ``TYPE_CHECKING``.
"""

from __future__ import annotations

import ast
import graphlib
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("multicosim", "pytest_multicosim")
MAX_LINES = 600


def _modules() -> dict[str, Path]:
    found: dict[str, Path] = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            found[".".join(parts)] = path
    return found


MODULES = _modules()


def _is_package(module: str) -> bool:
    return MODULES[module].name == "__init__.py"


def _owner(module: str) -> str:
    """The package a module belongs to: ``multicosim.px4`` for ``multicosim.px4.sitl``;
    the root package for the root's own modules (``multicosim.testing``)."""
    parts = module.split(".")
    if len(parts) > 2 or (len(parts) == 2 and _is_package(module)):
        return ".".join(parts[:2])
    return parts[0]


def _imports(module: str) -> Iterator[tuple[str, str | None, int]]:
    """(imported module, imported name or None, line) for every import in ``module``."""
    path = MODULES[module]
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    here = module if _is_package(module) else module.rpartition(".")[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, None, node.lineno
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = here.split(".")[: len(here.split(".")) - (node.level - 1)]
                base = ".".join([*anchor, *([node.module] if node.module else [])])
            for alias in node.names:
                full = f"{base}.{alias.name}"
                if full in MODULES:  # ``from package import module``
                    yield full, None, node.lineno
                else:
                    yield base, alias.name, node.lineno


def _ours(target: str) -> str | None:
    """The module of ours that ``target`` is or lies in, if any."""
    while target and target not in MODULES:
        target = target.rpartition(".")[0]
    return target or None


def test_no_import_cycle() -> None:
    graph = {
        module: {t for name, _, _ in _imports(module) if (t := _ours(name)) and t != module}
        for module in MODULES
    }
    try:
        tuple(graphlib.TopologicalSorter(graph).static_order())
    except graphlib.CycleError as cycle:
        pytest.fail(f"import cycle: {' -> '.join(cycle.args[1])}")


def test_no_package_imports_another_packages_private_parts() -> None:
    offences = []
    for module in MODULES:
        for name, attribute, line in _imports(module):
            target = _ours(name)
            if target is None or _owner(target) == _owner(module):
                continue
            private_module = any(p.startswith("_") and p != "__init__" for p in name.split("."))
            private_name = (attribute or "").startswith("_") and not (attribute or "").startswith(
                "__"
            )
            if private_module or private_name:
                shown = f"{name}.{attribute}" if attribute else name
                offences.append(f"{MODULES[module].relative_to(ROOT)}:{line} imports {shown}")
    assert not offences, "imports of another package's private parts:\n" + "\n".join(offences)


def test_no_file_over_the_limit() -> None:
    long = {
        str(path.relative_to(ROOT)): n
        for path in MODULES.values()
        if (n := len(path.read_text(encoding="utf-8").splitlines())) > MAX_LINES
    }
    assert not long, f"files over {MAX_LINES} lines (split them by concern): {long}"


def test_the_world_knows_no_vehicle() -> None:
    vehicles = (
        "multicosim.px4",
        "multicosim.rover",
        "multicosim.ardupilot",
        "multicosim.mavlink",
        "multicosim.quadrotor",
    )
    reached = {
        target
        for module in MODULES
        if _owner(module) == "multicosim.physics"
        for name, _, _ in _imports(module)
        if (target := _ours(name)) and target.startswith(vehicles)
    }
    assert not reached, f"multicosim.physics imports vehicles: {sorted(reached)}"


def test_the_check_sees_private_imports() -> None:
    # The walker itself: the rover's package imports its own private modules, which is fine,
    # and those imports are found (a walker that saw none would pass every check above).
    found = {name for name, _, _ in _imports("multicosim.rover")}
    assert "multicosim.rover._scenario" in found
    assert _owner("multicosim.rover._scenario") == _owner("multicosim.rover") == "multicosim.rover"
    assert _owner("multicosim.testing") == "multicosim"


# -- placements, neutral layers and private state ---------------------------------------------

PLACEMENT_PACKAGES = ("multicosim.placement", "multicosim.docker", "multicosim.ray")
"""Where components are placed: the only packages that may ask which placement runs."""
_SETTINGS = {"backend", "placement", "where", "in_process"}
_KINDS = {"docker", "process", "in-process", "container", "ray"}


def _tree(module: str) -> ast.AST:
    path = MODULES[module]
    return ast.parse(path.read_text(encoding="utf-8"), str(path))


def _names_a_setting(node: ast.expr) -> bool:
    text = ast.unparse(node)
    return any(word in text for word in _SETTINGS)


def _kinds(node: ast.expr) -> bool:
    """Whether ``node`` is a placement's name, or a collection of them."""
    items = node.elts if isinstance(node, ast.Tuple | ast.List | ast.Set) else [node]
    return any(isinstance(i, ast.Constant) and i.value in _KINDS for i in items)


def _placement_switches(tree: ast.AST) -> Iterator[int]:
    """Lines that decide by a placement's (or an old backend's) name, or by the container
    environment's class: there the placement should be asked instead."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Compare):
            sides = [node.left, *node.comparators]
            kinds = [s for s in sides if _kinds(s)]
            if kinds and any(_names_a_setting(s) for s in sides if s not in kinds):
                yield node.lineno
        elif (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Name)
            and node.func.id == "isinstance"
            and any("ContainerEnvironment" in ast.unparse(arg) for arg in node.args[1:])
        ):
            yield node.lineno


def test_no_placement_switch_outside_the_placements() -> None:
    offences = [
        f"{MODULES[module].relative_to(ROOT)}:{line}"
        for module in MODULES
        if not module.startswith(PLACEMENT_PACKAGES)
        for line in _placement_switches(_tree(module))
    ]
    assert not offences, "placement decided outside the placements (ask it):\n" + "\n".join(
        offences
    )


def test_the_switch_check_sees_a_switch() -> None:
    # The check itself: it finds what it is written to refuse, and passes what is fine.
    source = "\n".join(
        [
            'if backend == "docker": pass',
            'if self.placement.name != "process": pass',
            "if isinstance(environment, docker.ContainerEnvironment): pass",
            'if where in ("container", "process"): pass',
            'if fidelity == "low": pass',
            'if vehicle == "rover": pass',
        ]
    )
    assert list(_placement_switches(ast.parse(source))) == [1, 2, 3, 4]


def _private_names_defined(module: str) -> set[str]:
    """The private names ``module`` defines: methods, functions, class and instance attributes."""
    found: set[str] = set()
    for node in ast.walk(_tree(module)):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            found.add(node.name)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            found.add(node.attr)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            found.add(node.id)
    return {n for n in found if n.startswith("_") and not n.startswith("__")}


def _private_reads(module: str, theirs: dict[str, set[str]]) -> Iterator[str]:
    """Reads in ``module`` of another package's private attribute (``x._name`` where only
    another package of ours defines ``_name``)."""
    own = theirs[_owner(module)]
    others = set().union(*(names for owner, names in theirs.items() if owner != _owner(module)))
    for node in ast.walk(_tree(module)):
        if not isinstance(node, ast.Attribute) or not node.attr.startswith("_"):
            continue
        if node.attr.startswith("__") or node.attr in own or node.attr not in others:
            continue
        if isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"):
            continue
        yield f"{MODULES[module].relative_to(ROOT)}:{node.lineno} reads .{node.attr}"


def test_no_package_reads_another_packages_private_attributes() -> None:
    defined: dict[str, set[str]] = {}
    for module in MODULES:
        defined.setdefault(_owner(module), set()).update(_private_names_defined(module))
    offences = [line for module in MODULES for line in _private_reads(module, defined)]
    assert not offences, "private attributes of another package read:\n" + "\n".join(offences)


# Of PX4's: its flight modes and their encoding, its ground-station procedure, its simulator
# interface, its topics.
_PX4_OWN = {
    "MainMode",
    "SubMode",
    "Mode",
    "encode_custom_mode",
    "decode_custom_mode",
    "PX4Procedure",
    "HilTcpBridge",
    "SIM_PORT",
}


def _px4_in(module: str) -> Iterator[str]:
    """What of PX4's own ``module`` names: its modes, procedure, simulator or topics."""
    for node in ast.walk(_tree(module)):
        if isinstance(node, ast.Name | ast.Attribute | ast.ClassDef | ast.FunctionDef):
            name = (
                node.id
                if isinstance(node, ast.Name)
                else node.attr
                if isinstance(node, ast.Attribute)
                else node.name
            )
            if name in _PX4_OWN:
                yield f"{MODULES[module].relative_to(ROOT)}:{node.lineno} {name}"
        if (
            isinstance(node, ast.Constant)
            and isinstance(node.value, str)
            and node.value.startswith("px4/")
        ):
            yield f"{MODULES[module].relative_to(ROOT)}:{node.lineno} topic {node.value!r}"
    for name, _, line in _imports(module):
        if (_ours(name) or "").startswith("multicosim.px4"):
            yield f"{MODULES[module].relative_to(ROOT)}:{line} imports {name}"


def test_the_shared_mavlink_layer_holds_nothing_of_px4s() -> None:
    offences = [
        found
        for module in MODULES
        if _owner(module) == "multicosim.mavlink"
        for found in _px4_in(module)
    ]
    assert not offences, "PX4's own in multicosim.mavlink:\n" + "\n".join(offences)
    # The check itself: PX4's package is full of what it looks for.
    assert any(True for _ in _px4_in("multicosim.px4.procedure"))
