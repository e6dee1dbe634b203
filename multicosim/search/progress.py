"""A progress bar for long searches and campaigns: on a terminal only, quiet elsewhere."""

from __future__ import annotations

import sys
from types import TracebackType
from typing import Any

__all__ = ["ProgressBar", "wanted"]


def wanted(progress: bool | None) -> bool:
    """Whether to show a bar: ``None`` (auto) shows one when stderr is a terminal and tqdm is
    installed; ``True`` always (DependencyMissingError without tqdm)."""
    if progress is None:
        import importlib.util

        isatty = getattr(sys.stderr, "isatty", None)
        tty = bool(isatty is not None and isatty())
        return tty and importlib.util.find_spec("tqdm") is not None
    return bool(progress)


class ProgressBar:
    """Simulations done of ``total``, a status (best robustness, violations) and the ETA.

    A tqdm bar on stderr when ``enabled``; every method does nothing otherwise, and tqdm is
    imported only for a bar that is shown.
    """

    def __init__(self, enabled: bool, total: int, label: str) -> None:
        self._bar: Any = None
        if enabled:
            from ..core.deps import require

            tqdm = require("tqdm", "search")
            self._bar = tqdm.tqdm(
                total=total, desc=label, unit="sim", file=sys.stderr, dynamic_ncols=True
            )

    def grow(self, more: int) -> None:
        """Raise the total by ``more`` (a campaign's next batch)."""
        if self._bar is not None:
            self._bar.total = (self._bar.total or 0) + more
            self._bar.refresh()

    def advance(self, status: str = "", n: int = 1) -> None:
        """``n`` more simulations done; ``status`` replaces the text after the bar."""
        if self._bar is not None:
            if status:
                self._bar.set_postfix_str(status, refresh=False)
            self._bar.update(n)

    def close(self) -> None:
        """Finish the bar (idempotent)."""
        bar, self._bar = self._bar, None
        if bar is not None:
            bar.close()

    def __enter__(self) -> ProgressBar:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()
