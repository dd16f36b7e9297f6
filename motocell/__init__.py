"""motocell: a MotoROS-compatible robot controller for simulated Yaskawa Motoman cells."""

__version__ = "0.1.0"
"""The version, as ``motocell --version`` and every service's description give it; the
package's metadata takes it from here (pyproject.toml)."""
