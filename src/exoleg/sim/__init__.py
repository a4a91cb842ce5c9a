"""Simulation: fixed-step integration of the leg's dynamics."""
