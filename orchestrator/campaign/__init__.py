"""Campaigns: designs over a base case, content-addressed runs, executors, index, calibration."""
