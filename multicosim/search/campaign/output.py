"""What a campaign writes under its ``output`` directory.

``results.csv`` (and ``results.parquet`` where pyarrow is installed) holds one row per sample:
its index, seed, status, robustness, the sample's fields as ``sample.NAME`` and the
trajectory summary as ``summary.NAME``. The traces of samples that did not pass go to
``traces/sample-NNNNN/``.
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import importlib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import msgspec

from .results import SampleResult

__all__ = ["save_traces", "write_results"]


def save_traces(output: Path, index: int, traces: Mapping[str, bytes]) -> tuple[Path, ...]:
    """Write a sample's trace files (name -> bytes) under ``output/traces``; their paths."""
    if not traces:
        return ()
    directory = output / "traces" / f"sample-{index:05d}"
    directory.mkdir(parents=True, exist_ok=True)
    saved = []
    for name, data in sorted(traces.items()):
        path = directory / name
        path.write_bytes(data)
        saved.append(path)
    return tuple(saved)


def write_results(output: Path, results: Sequence[SampleResult]) -> tuple[Path, Path | None]:
    """Write ``results`` as ``output/results.csv`` and, with pyarrow, ``results.parquet``;
    return both paths (None: no parquet)."""
    output.mkdir(parents=True, exist_ok=True)
    rows = [_row(result) for result in results]
    header = list(dict.fromkeys(key for row in rows for key in row))
    csv_path = output / "results.csv"
    with csv_path.open("w", newline="") as stream:
        writer = csv.DictWriter(stream, fieldnames=header, restval="")
        writer.writeheader()
        writer.writerows(rows)
    parquet_path = None
    with contextlib.suppress(ImportError):
        pa = importlib.import_module("pyarrow")
        pq = importlib.import_module("pyarrow.parquet")
        parquet_path = output / "results.parquet"
        pq.write_table(pa.Table.from_pylist(rows), parquet_path)
    return csv_path, parquet_path


def _flatten(sample: Any) -> dict[str, Any]:
    if isinstance(sample, Mapping):
        return {str(k): v for k, v in sample.items()}
    if isinstance(sample, msgspec.Struct):
        return {f: getattr(sample, f) for f in sample.__struct_fields__}
    if dataclasses.is_dataclass(sample) and not isinstance(sample, type):
        return {f.name: getattr(sample, f.name) for f in dataclasses.fields(sample)}
    return {"": sample}


def _cell(value: Any) -> Any:
    return value if isinstance(value, bool | int | float | str) or value is None else repr(value)


def _row(result: SampleResult) -> dict[str, Any]:
    row: dict[str, Any] = {
        "index": result.index,
        "seed": result.seed,
        "status": result.status,
        "robustness": result.robustness,
        "attempts": result.attempts,
        "wall_time": result.wall_time,
        "worker": result.worker,
        "error": result.error,
        "trace": ";".join(str(p) for p in result.trace),
    }
    for key, value in _flatten(result.sample).items():
        row["sample" + (f".{key}" if key else "")] = _cell(value)
    for key, value in result.summary.items():
        row[f"summary.{key}"] = _cell(value)
    return row
