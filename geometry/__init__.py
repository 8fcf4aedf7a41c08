"""Rough surfaces: read, generate, detrend, make periodic, interpolate, statistics; gmsh meshing.

Everything here imports without dolfinx, gmsh or MPI; ``geometry.mesh`` needs gmsh to build
its model, and nothing here uses dolfinx or MPI (the solver turns the model into a dolfinx mesh).
"""
