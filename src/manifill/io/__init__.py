"""Files in and out: one registry of mesh formats, samples, solids, VTK and neuroimaging files."""
