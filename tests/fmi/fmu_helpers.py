"""FMUs built to fail: the Reference FMUs' Dahlquist, rebuilt from its own C sources with a
fault from t = 0.5 s on, so that errors, crashes and log messages come from real native code."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

from multicosim import fmi
from multicosim.fmi.build import prepare

FAULT_TIME = 0.5

# What the patched getDerivatives does from FAULT_TIME on (C, in the FMU's model.c).
FAULTS = {
    "error": 'logError(comp, "injected fault at t=%g", comp->time); return Error;',
    "fatal": 'logError(comp, "injected fatal fault at t=%g", comp->time); return Fatal;',
    "discard": 'logError(comp, "injected discard at t=%g", comp->time); return Discard;',
    "abort": 'logError(comp, "injected fault: aborting at t=%g", comp->time); abort();',
    # Not a fault: an event logged every step (with debug logging on), the run goes on.
    "log": 'logEvent(comp, "injected event at t=%g", comp->time);',
}


def sources_only(reference: Path, directory: Path, fault: str | None = None) -> Path:
    """Dahlquist (FMI 2) extracted into ``directory`` without its binaries, its sources
    patched with ``fault`` (None: unchanged): an FMU only ``compile=True`` can run."""
    from fmpy import extract

    extract(str(reference / "fmi2" / "Dahlquist.fmu"), str(directory))
    shutil.rmtree(directory / "binaries")
    if fault is not None:
        model_c = directory / "sources" / "model.c"
        text = model_c.read_text()
        head = "Status getDerivatives(ModelInstance *comp, double dx[], size_t nx) {"
        assert head in text, "the Reference FMU's getDerivatives changed"
        inject = f"\n    if (comp->time >= {FAULT_TIME}) {{ {FAULTS[fault]} }}\n"
        text = text.replace(head, head + inject)
        model_c.write_text("#include <stdlib.h>\n" + text)
    return directory


def faulty(reference: Path, directory: Path, fault: str) -> Path:
    """A runnable FMU directory: Dahlquist with ``fault``, compiled with FMPy."""
    sources = sources_only(reference, directory / "sources", fault)
    return prepare(fmi.describe(sources), directory / "built")


def slug(text: str) -> str:
    """A file-name-safe form of ``text``."""
    return re.sub(r"[^A-Za-z0-9_.-]", "_", text)


def statespace_fixed(reference: Path, directory: Path) -> Path:
    """StateSpace (FMI 3) rebuilt from its sources with two upstream slips fixed, so that its
    structural parameters (m, n, r) can be set: v0.0.41's setUInt64 checks the number of
    values after advancing past one (every call fails), and its buildDescription.xml names
    the model's former identifier (LinearTransform)."""
    from fmpy import extract

    sources = directory / "sources"
    extract(str(reference / "fmi3" / "StateSpace.fmu"), str(sources))
    shutil.rmtree(sources / "binaries")
    model_c = sources / "sources" / "model.c"
    text = model_c.read_text()
    head = "Status setUInt64("
    start = text.index(head)
    end = text.index("\n}\n", start)
    body = text[start:end]
    slip = "    const uint64_t v = values[(*index)++];"
    assert slip in body, "the Reference FMU's setUInt64 changed"
    body = body.replace("            ASSERT_NVALUES(1);\n", "")
    body = body.replace(slip, "    ASSERT_NVALUES(1);\n" + slip)
    model_c.write_text(text[:start] + body + text[end:])
    build = sources / "sources" / "buildDescription.xml"
    build.write_text(build.read_text().replace('"LinearTransform"', '"StateSpace"'))
    return prepare(fmi.describe(sources), directory / "built")
