"""multicosim's version, in one place (the package, the images and the traces read it)."""

__version__ = "0.1.0"
