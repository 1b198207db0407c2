"""Weight-only int8 quantisation of an ONNX graph (per output channel, symmetric).

Why not ``onnxruntime.quantization.quantize_dynamic``: it also quantises ACTIVATIONS at run time
(DynamicQuantizeLinear, one scale per tensor), and tiny float differences between runtimes flip
those roundings: the same dynamic-int8 MiniLM file gave sentence cosines down to 0.9967 between
onnxruntime 1.32 (Python) and onnxruntime-node 1.21 (transformers.js), and batching prompts changed
vectors by as much (cosine 0.992). Storing only the WEIGHTS as int8 (one scale per output channel /
per embedding row) and computing in float32 keeps the file just as small (~23 MB for MiniLM) while
every runtime computes the same float graph.

- MatMul with a constant 2-D weight W [K, N]: W ≈ q·s[n], q int8 in [-127, 127];
  Cast(q) · s feeds the MatMul. Both inputs are constants, so ONNX Runtime's constant folding
  (native and web) expands the weights once at session start; the per-call cost is a float MatMul.
- Gather from a constant 2-D table T [V, D] (embeddings): rows quantised with one scale each;
  Gather(q) → Cast(float) → Mul(Gather(s[V,1])), so only the looked-up rows are expanded.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def quantize_rows(w: np.ndarray, axis: int) -> tuple[np.ndarray, np.ndarray]:
    """Symmetric int8 per slice along ``axis`` (the axis that keeps its own scale)."""
    w = np.asarray(w, np.float32)
    red = tuple(i for i in range(w.ndim) if i != axis)
    amax = np.abs(w).max(axis=red, keepdims=True)
    scale = np.where(amax > 0, amax / 127.0, 1.0).astype(np.float32)
    q = np.clip(np.rint(w / scale), -127, 127).astype(np.int8)
    return q, scale.reshape(-1)


def quantize_weights_int8(src: Path | str, dst: Path | str, min_elements: int = 4096) -> dict[str, int]:
    """Rewrite ``src`` into ``dst`` with int8 weights; returns counts of rewritten MatMul / Gather."""
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    model = onnx.load(str(src))
    g = model.graph
    inits = {i.name: i for i in g.initializer}
    consumers: dict[str, int] = {}
    for n in g.node:
        for i in n.input:
            consumers[i] = consumers.get(i, 0) + 1
    new_nodes, counts, drop = [], {"MatMul": 0, "Gather": 0}, set()
    for n in g.node:
        if n.op_type == "MatMul" and n.input[1] in inits and consumers.get(n.input[1]) == 1:
            w = numpy_helper.to_array(inits[n.input[1]])
            if w.ndim == 2 and w.dtype == np.float32 and w.size >= min_elements:
                name = n.input[1]
                q, s = quantize_rows(w, axis=1)
                g.initializer.extend([numpy_helper.from_array(q, f"{name}_q"),
                                      numpy_helper.from_array(s.reshape(1, -1), f"{name}_scale")])
                new_nodes += [
                    helper.make_node("Cast", [f"{name}_q"], [f"{name}_f"], name=f"{name}_Cast", to=TensorProto.FLOAT),
                    helper.make_node("Mul", [f"{name}_f", f"{name}_scale"], [f"{name}_deq"], name=f"{name}_Dequant"),
                ]
                n.input[1] = f"{name}_deq"
                drop.add(name)
                counts["MatMul"] += 1
        elif n.op_type == "Gather" and n.input[0] in inits and consumers.get(n.input[0]) == 1:
            attrs = {a.name: helper.get_attribute_value(a) for a in n.attribute}
            w = numpy_helper.to_array(inits[n.input[0]])
            if attrs.get("axis", 0) == 0 and w.ndim == 2 and w.dtype == np.float32 and w.size >= min_elements:
                name, out = n.input[0], n.output[0]
                q, s = quantize_rows(w, axis=0)
                g.initializer.extend([numpy_helper.from_array(q, f"{name}_q"),
                                      numpy_helper.from_array(s.reshape(-1, 1), f"{name}_scale")])
                idx = n.input[1]
                new_nodes += [
                    helper.make_node("Gather", [f"{name}_q", idx], [f"{out}_q"], name=f"{n.name or out}_q", axis=0),
                    helper.make_node("Cast", [f"{out}_q"], [f"{out}_f"], name=f"{out}_Cast", to=TensorProto.FLOAT),
                    helper.make_node("Gather", [f"{name}_scale", idx], [f"{out}_s"], name=f"{out}_scale", axis=0),
                    helper.make_node("Mul", [f"{out}_f", f"{out}_s"], [out], name=f"{out}_Mul"),
                ]
                drop.add(name)
                counts["Gather"] += 1
                continue
        new_nodes.append(n)
    kept = [i for i in g.initializer if i.name not in drop]
    del g.initializer[:]
    g.initializer.extend(kept)
    del g.node[:]
    g.node.extend(new_nodes)
    onnx.checker.check_model(model)
    Path(dst).parent.mkdir(parents=True, exist_ok=True)
    onnx.save(model, str(dst))
    return counts
