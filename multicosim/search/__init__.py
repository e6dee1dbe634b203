"""Testing a system against its requirements: STL requirements and their robustness
(:mod:`.requirements`), campaigns over a design of experiments (:mod:`.campaign`),
falsifying searches (:mod:`.falsify`, :mod:`.taliro`) and Hypothesis strategies
(:mod:`.strategies`).

The public modules are also importable under their former names (``multicosim.requirements``,
``multicosim.campaign``, ``multicosim.falsify``, ``multicosim.taliro``,
``multicosim.strategies``).
"""
