"""ONNX export and quantisation without their noise: ``torch.onnx.export(dynamo=True)`` logs one warning per
torchvision operator it could register when torchvision is not installed (we need none), and onnxruntime's
``quantize_dynamic`` asks on the root logger for a pre-processing step our graphs do not need (the parity and
int8-error figures each export prints are what says whether a file is good). Python ``warnings`` are ignored meanwhile
(the exporter's deprecation and tracer warnings, as ``emdm.export`` always did); other log records and errors show.
"""

from __future__ import annotations

import contextlib
import logging
import warnings
from collections.abc import Iterator

_REGISTRATION = "torch.onnx._internal.exporter._registration"
_QUANT_NOTICE = "Please consider to run pre-processing before quantization"


class _DropQuantNotice(logging.Filter):
    def filter(self, record: logging.LogRecord) -> bool:
        return not record.getMessage().startswith(_QUANT_NOTICE)


@contextlib.contextmanager
def quiet_onnx_tools() -> Iterator[None]:
    """Run an export or a quantisation with the two known notices above silenced, and Python warnings ignored."""
    reg = logging.getLogger(_REGISTRATION)
    level = reg.level
    drop = _DropQuantNotice()
    root = logging.getLogger()
    reg.setLevel(logging.ERROR)
    root.addFilter(drop)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            yield
    finally:
        reg.setLevel(level)
        root.removeFilter(drop)
