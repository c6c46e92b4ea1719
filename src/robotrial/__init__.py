"""robotrial: try a robot in simulation before it is bought or built."""

__version__ = "0.1.0"
