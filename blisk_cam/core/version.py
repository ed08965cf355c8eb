"""The product's version, the one place it is written (``blender_manifest.toml`` and
``pyproject.toml`` say the same; ``tests/core/test_version.py`` checks them)."""

__version__ = "0.1.0"
