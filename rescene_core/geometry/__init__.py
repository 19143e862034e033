"""Geometry helpers: Sim(3), projection, planes, meshes."""
