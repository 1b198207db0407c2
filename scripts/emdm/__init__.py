"""EMDM in the browser: the Python pipeline (data, training, evaluation, export) and ``emdm.generate``.

    import emdm
    motion = emdm.generate("a person walks forward", seconds=6, models_dir="path/to/models")
    motion.write_bvh("walk.bvh"); motion.write_glb("walk.glb")

Sampling needs numpy, onnxruntime and tokenizers only (``pip install emdm``); training, export and evaluation need
``pip install "emdm[train]"`` (torch and the rest). The models folder is not in the package: docs/PYTHON.md.
"""

__version__ = "0.1.0"
__all__ = ["Motion", "PromptWarning", "generate", "__version__"]


def __getattr__(name: str):
    # emdm.generate / emdm.Motion load emdm.generation on first use: `import emdm` (every console script and
    # `python -m emdm.*` runs it) stays free of onnxruntime, the text encoders and the sampler until they are asked for.
    if name in ("generate", "Motion", "PromptWarning"):
        from emdm import generation  # lazy: `import emdm` stays light (see above)

        return getattr(generation, name)
    raise AttributeError(f"module 'emdm' has no attribute {name!r}")
