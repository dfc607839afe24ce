"""Surfaces as arrays: edges, topology, geometry, cleaning, Laplacians, graphs, built-in shapes, subdivision."""
