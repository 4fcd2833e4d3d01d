"""YADE: adapter and per-material constants."""
