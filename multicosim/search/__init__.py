"""Testing a system against its requirements: STL requirements and their robustness
(:mod:`.requirements`), campaigns over a design of experiments (:mod:`.campaign`),
falsifying searches (:mod:`.falsify`, :mod:`.taliro`) and Hypothesis strategies
(:mod:`.strategies`).
"""
