"""Surfaces as arrays: edges, topology, geometry, cleaning, Laplacians, graphs, built-in shapes, subdivision.

- :mod:`manifill.mesh.edges` - the edge index (``EdgeIndex``), edges, adjacency
- :mod:`manifill.mesh.topology` - components, boundary loops, genus, ``mesh_info``
- :mod:`manifill.mesh.geometry` - cotangents, face areas, vertex areas
- :mod:`manifill.mesh.clean` - ``clean_mesh``
- :mod:`manifill.mesh.laplacian` - the stiffness matrix ``laplacian`` and the mass matrix ``mass_matrix``
- :mod:`manifill.mesh.graph` - distances on the mesh graph
- :mod:`manifill.mesh.shapes` - built-in meshes
- :mod:`manifill.mesh.subdivide` - Loop subdivision
- :mod:`manifill.mesh.objects` - pyvista, trimesh and meshio objects in and out
"""
