"""Tangent vector fields on surfaces: the connection, the vector fill, line and cross fields, Hodge fits."""
