"""URB schema compiler: parses *.urbs files, checks them, and emits C and Python codecs."""

__version__ = "0.1.0"
