"""URB host (CPU) library and the `urb` command line."""

__version__ = "0.1.0"
