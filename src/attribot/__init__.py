"""attribot: LLM-written programs over a perception-action API that discover object attributes.

Importing the package has no side effects: no render backend is chosen, no model is loaded.
"""

__all__ = ["__version__"]

__version__ = "0.1.0"
