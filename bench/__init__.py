"""multicosim's benchmarks: ``python -m bench`` runs them all (``--quick`` for a short run).

Each ``bench/bench_NAME.py`` also runs alone (``python bench/bench_NAME.py``) and writes
``bench/results/NAME.json``; ``python -m bench`` runs every one of them side by side, prints
one table, writes ``bench/results/all.json`` and regenerates docs/benchmarks.md's figures.
"""
