"""The paper's Steps 7-8: the solid's boundary, voxels and tetrahedra, and the fill of the inside."""
