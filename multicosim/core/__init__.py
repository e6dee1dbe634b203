"""The core every layer stands on: errors, the wire protocol, messages, the simulated clock,
the paper's interfaces, fidelity names and geodesy.

It imports nothing else of multicosim and nothing heavy: ``import multicosim`` loads only
this, msgspec and the standard library.
"""
