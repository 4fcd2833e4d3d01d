"""dem-orchestrator: one case file, LIGGGHTS or YADE, one HDF5 result store."""

__version__ = "0.1.0"
