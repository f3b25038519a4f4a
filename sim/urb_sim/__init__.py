"""Time-accurate simulation of URB buses running the real firmware (C core, Python scenarios)."""
