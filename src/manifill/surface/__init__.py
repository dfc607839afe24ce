"""The paper's Steps 1-6 on a surface: gradual variation, partition, curve values, the harmonic fill."""
