"""Validation campaign: cross-checks, accuracy/stability studies and benchmarks."""
