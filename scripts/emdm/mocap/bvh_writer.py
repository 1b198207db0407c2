"""Moved to ``emdm.writers.bvh`` (issue 31: the writers sit together, apart from the mocap readers).

Re-exported here only for ``emdm.sample``, which imports it from this path until its own rewrite lands.
"""

from emdm.writers.bvh import bvh_path, bvh_text, write_bvh

__all__ = ["bvh_path", "bvh_text", "write_bvh"]
