"""Benchmarks: manifill beside its peers (``python -m bench all``), and the older single-purpose scripts."""
