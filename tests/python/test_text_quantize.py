"""Weight-only int8 quantisation (emdm.text.quantize): bounded error, same outputs, smaller file."""

from __future__ import annotations

import numpy as np
import onnx
import onnxruntime as ort
from onnx import TensorProto, helper, numpy_helper

from emdm.text.quantize import quantize_rows, quantize_weights_int8


def test_quantize_rows_error_is_within_half_a_step():
    rng = np.random.default_rng(0)
    w = rng.normal(size=(64, 32)).astype(np.float32)
    w[:, 3] = 0.0  # an all-zero channel must not divide by zero
    q, s = quantize_rows(w, axis=1)
    assert q.dtype == np.int8 and s.shape == (32,) and np.abs(q).max() <= 127
    err = np.abs(q.astype(np.float32) * s[None, :] - w)
    assert (err <= s[None, :] / 2 + 1e-7).all()
    assert (q[:, 3] == 0).all()


def _tiny_model(path):
    rng = np.random.default_rng(1)
    emb = rng.normal(size=(100, 64)).astype(np.float32)
    w = rng.normal(size=(64, 128)).astype(np.float32)
    nodes = [helper.make_node("Gather", ["emb", "ids"], ["e"], axis=0), helper.make_node("MatMul", ["e", "w"], ["y"])]
    g = helper.make_graph(nodes, "tiny", [helper.make_tensor_value_info("ids", TensorProto.INT64, ["b", "t"])],
                          [helper.make_tensor_value_info("y", TensorProto.FLOAT, ["b", "t", 128])],
                          [numpy_helper.from_array(emb, "emb"), numpy_helper.from_array(w, "w")])
    onnx.save(helper.make_model(g, opset_imports=[helper.make_opsetid("", 18)]), str(path))


def test_rewritten_graph_gives_the_same_outputs_and_is_smaller(tmp_path):
    src, dst = tmp_path / "f.onnx", tmp_path / "q.onnx"
    _tiny_model(src)
    assert quantize_weights_int8(src, dst) == {"MatMul": 1, "Gather": 1}
    assert dst.stat().st_size < src.stat().st_size / 3
    ids = np.array([[0, 5, 99], [7, 7, 1]], np.int64)
    a = ort.InferenceSession(str(src), providers=["CPUExecutionProvider"]).run(None, {"ids": ids})[0]
    b = ort.InferenceSession(str(dst), providers=["CPUExecutionProvider"]).run(None, {"ids": ids})[0]
    assert np.abs(a - b).max() < 0.05 * np.abs(a).max()
    types = {n.op_type for n in onnx.load(str(dst)).graph.node}
    assert {"Cast", "Mul", "Gather", "MatMul"} <= types
