"""Rough surfaces: read, generate, detrend, make periodic, interpolate, statistics; gmsh meshing.

Everything here but ``geometry.mesh`` imports without dolfinx or gmsh.
"""
