"""EMDM in the browser: the Python pipeline (data, training, evaluation, export) and ``emdm.generate``.

    import emdm
    motion = emdm.generate("a person walks forward", seconds=6, models_dir="path/to/models")
    motion.write_bvh("walk.bvh"); motion.write_glb("walk.glb")

Sampling needs numpy, onnxruntime and tokenizers only (``pip install emdm``); training, export and evaluation need
``pip install "emdm[train]"`` (torch and the rest). The models folder is not in the package: docs/MODELS.md.
"""

__version__ = "0.1.0"

from emdm.generation import Motion, generate  # noqa: E402 - after __version__, which the modules below may read

__all__ = ["Motion", "generate", "__version__"]
