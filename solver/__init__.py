"""Deterministic FEM (dolfinx 0.5): material, contact and friction, load stepping, output.

``solver.material`` is NumPy only (the theory uses the same ``Material``); the other modules
import dolfinx.
"""
