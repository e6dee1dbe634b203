"""The F-16 tests (``aerobench`` is the plugin's fixture).

In-process pytester runs forget the modules first imported inside them, and scipy's C
extensions cannot be imported twice in a process: the outer session imports what the F-16
uses before any inner run can.
"""

from __future__ import annotations

import scipy.integrate  # noqa: F401
