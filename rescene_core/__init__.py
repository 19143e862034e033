"""ReScene: multi-view indoor capture -> simulation-ready object-level scene. Prefect-free library."""

__version__ = "0.1.0"
