"""What an ONNX policy's graph may hold, and what one inference of it costs: checked before
onnxruntime sees the file (docs/design/onnx.md#onnx-policies).

A file is a program onnxruntime runs, and most ONNX operators make its run time or memory a
function of the data (Loop, Scan, If, Expand, ConstantOfShape, Range, Resize, ...). A policy
is only ever the graph ``onnx_export`` writes, so a file is run only if it is that kind of
graph:

* operators from ``ALLOWED_OPS`` only (what the exporter emits: Gemm, Relu, ReduceMean, Add,
  Sub), in the default domain of opset ``OPSET``, with only the attributes listed there, no
  subgraph or tensor attribute, no model-local function;
* one graph input ``obs`` (B, obs_dim) and weights stored inside the file, float32, of rank
  <= 2: external data (read from a path the file names) is refused;
* every tensor's shape is known for one observation (B = 1, propagated here through the five
  operators), rank <= 2, and the graph output is (1, |A|);
* one inference holds at most ``MAX_ONNX_ELEMENTS`` floats and does at most
  ``MAX_ONNX_MACS`` multiply-adds; ``MAX_ONNX_NODES`` operators at most.

With rank <= 2, ReduceMean keeping its axes and Gemm's weights constant, only a tensor's
first axis can follow the batch, so a batch of B costs at most B times one observation
(beyond the weights): :meth:`GraphCost.rows_per_run` bounds a batch's memory by that.

Pure: numpy and the ``onnx`` protobuf classes (the ``robot`` extra, imported by the caller).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from d3dwa_bullet.errors import CheckpointError
from d3dwa_bullet.limits import MAX_ONNX_ELEMENTS, MAX_ONNX_MACS, MAX_ONNX_NODES

OPSET = 17
"""ONNX operator set of exported graphs (ReduceMean still takes its axes as an attribute)."""
ALLOWED_OPS: dict[str, frozenset[str]] = {
    "Gemm": frozenset({"alpha", "beta", "transA", "transB"}),
    "Relu": frozenset(),
    "ReduceMean": frozenset({"axes", "keepdims"}),
    "Add": frozenset(),
    "Sub": frozenset(),
}
"""Operator -> the attributes it may carry: what ``onnx_export.onnx_model`` writes."""
_DEFAULT_DOMAINS = ("", "ai.onnx")
_MAX_RANK = 2
_TENSOR_FLOAT = 1  # onnx.TensorProto.FLOAT
_ATTR_INT, _ATTR_INTS, _ATTR_FLOAT = 2, 7, 1  # onnx.AttributeProto types

Shape = tuple[int, ...]


@dataclass(frozen=True)
class GraphCost:
    """What one inference costs: weights (floats), intermediates per observation (floats),
    multiply-adds per observation."""

    weights: int
    per_row: int
    macs: int

    def rows_per_run(self) -> int:
        """Observations one run may take and still hold at most MAX_ONNX_ELEMENTS floats."""
        room = int(MAX_ONNX_ELEMENTS.value) - self.weights
        return max(1, room // max(1, self.per_row))


def check_graph(model: Any, where: str, input_name: str, output_name: str) -> GraphCost:
    """Check an ``onnx.ModelProto`` against the module docstring's rules; its cost, or a
    CheckpointError naming ``where`` and the first thing refused."""
    graph = model.graph

    def refuse(what: str) -> CheckpointError:
        return CheckpointError(f"{where}: refused before running: {what}")

    opsets = [(o.domain, o.version) for o in model.opset_import]
    if len(opsets) != 1 or opsets[0][0] not in _DEFAULT_DOMAINS or opsets[0][1] != OPSET:
        raise refuse(f"it imports opsets {opsets}; an exported policy uses ('', {OPSET}) only")
    if len(model.functions):
        raise refuse("it defines model-local functions; an exported policy has none")
    if len(graph.sparse_initializer):
        raise refuse("it has sparse initializers; an exported policy has none")
    first = f"{where}: refused before running"
    MAX_ONNX_NODES.check(f"{first}: operators", len(graph.node), "", CheckpointError)
    for index, node in enumerate(graph.node):
        _check_operator(node, _label(index, node), refuse)
    shapes: dict[str, Shape] = {}
    weights = 0
    for tensor in graph.initializer:
        shape = _weight_shape(tensor, refuse)
        weights += int(np.prod(shape, dtype=np.int64))
        MAX_ONNX_ELEMENTS.check(f"{first}: weights", weights, "floats", CheckpointError)
        shapes[tensor.name] = shape
    constants = set(shapes)
    inputs = [i for i in graph.input if i.name not in constants]
    if [i.name for i in inputs] != [input_name]:
        raise refuse(f"graph inputs {[i.name for i in inputs]}; a policy has {[input_name]}")
    dims = inputs[0].type.tensor_type.shape.dim
    if len(dims) != 2 or not dims[1].HasField("dim_value"):
        raise refuse(f"input {input_name!r} is not (batch, obs_dim) with obs_dim fixed")
    shapes[input_name] = (1, int(dims[1].dim_value))
    per_row = macs = 0
    for index, node in enumerate(graph.node):
        out, cost = _node(node, _label(index, node), shapes, constants, refuse)
        per_row += int(np.prod(out, dtype=np.int64))
        macs += cost
        MAX_ONNX_ELEMENTS.check(
            f"{first}: one inference", weights + per_row, "floats", CheckpointError
        )
        MAX_ONNX_MACS.check(f"{first}: one inference", macs, "multiply-adds", CheckpointError)
        shapes[node.output[0]] = out
    outputs = [o.name for o in graph.output]
    if outputs != [output_name] or output_name not in shapes:
        raise refuse(f"graph outputs {outputs}; a policy computes {[output_name]}")
    if len(shapes[output_name]) != 2 or shapes[output_name][0] != 1:
        raise refuse(f"output {output_name!r} is {shapes[output_name]} for one observation")
    return GraphCost(weights, per_row, macs)


def _weight_shape(tensor: Any, refuse: Any) -> Shape:
    name = tensor.name
    if tensor.data_location == 1 or len(tensor.external_data):  # TensorProto.EXTERNAL
        raise refuse(
            f"weight {name!r} is external data (read from a path the file names); an "
            "exported policy keeps every weight inside the file"
        )
    if tensor.data_type != _TENSOR_FLOAT:
        raise refuse(f"weight {name!r} is not float32 (ONNX type {tensor.data_type})")
    shape = tuple(int(d) for d in tensor.dims)
    if len(shape) > _MAX_RANK or any(d < 0 for d in shape):
        raise refuse(f"weight {name!r} has shape {shape}; weights have rank <= {_MAX_RANK}")
    return shape


_ATTRIBUTE_TYPES = (_ATTR_INT, _ATTR_INTS, _ATTR_FLOAT)


def _label(index: int, node: Any) -> str:
    return f"node {index} ({node.op_type}{' ' + repr(node.name) if node.name else ''})"


def _check_operator(node: Any, label: str, refuse: Any) -> None:
    """An allowed operator of the default domain with allowed attributes (no subgraph)."""
    op = node.op_type
    if node.domain not in _DEFAULT_DOMAINS or op not in ALLOWED_OPS:
        domain = f" of domain {node.domain!r}" if node.domain not in _DEFAULT_DOMAINS else ""
        raise refuse(
            f"{label}: operator {op!r}{domain} is not one an exported policy uses "
            f"({', '.join(ALLOWED_OPS)})"
        )
    for attr in node.attribute:
        if attr.name not in ALLOWED_OPS[op] or attr.type not in _ATTRIBUTE_TYPES:
            raise refuse(f"{label}: attribute {attr.name!r} is not one an export writes")


def _node(
    node: Any, label: str, shapes: dict[str, Shape], constants: set[str], refuse: Any
) -> tuple[Shape, int]:
    """(output shape for one observation, multiply-adds) of one allowed node."""
    op = node.op_type
    attrs = {attr.name: attr for attr in node.attribute}
    if len(node.output) != 1 or node.output[0] in shapes:
        raise refuse(f"{label}: outputs {list(node.output)}: one new tensor expected")
    missing = [name for name in node.input if name not in shapes]
    if missing:
        raise refuse(f"{label}: input(s) {missing} are not defined before it")
    args = [shapes[name] for name in node.input]
    if op == "Gemm":
        return _gemm(node, label, args, attrs, constants, refuse)
    if op == "ReduceMean":
        return _reduce_mean(label, args, attrs, refuse)
    if op == "Relu":
        if len(args) != 1:
            raise refuse(f"{label}: Relu takes one input")
        return args[0], int(np.prod(args[0]))
    if len(args) != 2:
        raise refuse(f"{label}: {op} takes two inputs")
    out = _broadcast(args[0], args[1], label, refuse)
    return out, int(np.prod(out))


def _gemm(node, label, args, attrs, constants, refuse) -> tuple[Shape, int]:
    if len(args) not in (2, 3) or any(name not in constants for name in node.input[1:]):
        raise refuse(f"{label}: Gemm's B and C must be weights stored in the file")
    a, b = args[0], args[1]
    if len(a) != 2 or len(b) != 2:
        raise refuse(f"{label}: Gemm of shapes {a} and {b}; both must be 2-D")
    trans_a = attrs["transA"].i if "transA" in attrs else 0
    trans_b = attrs["transB"].i if "transB" in attrs else 0
    m, k = (a[1], a[0]) if trans_a else a
    k_b, n = (b[1], b[0]) if trans_b else b
    if k != k_b:
        raise refuse(f"{label}: Gemm of shapes {a} and {b} (transA={trans_a}, transB={trans_b})")
    out = (m, n)
    if len(args) == 3 and _broadcast(args[2], out, label, refuse) != out:
        raise refuse(f"{label}: Gemm's C {args[2]} does not broadcast to {out}")
    return out, m * k * n + m * n


def _reduce_mean(label, args, attrs, refuse) -> tuple[Shape, int]:
    if len(args) != 1:
        raise refuse(f"{label}: ReduceMean takes one input")
    x = args[0]
    keepdims = attrs["keepdims"].i if "keepdims" in attrs else 1
    axes = list(attrs["axes"].ints) if "axes" in attrs else list(range(len(x)))
    if keepdims != 1 or not all(-len(x) <= axis < len(x) for axis in axes):
        raise refuse(f"{label}: ReduceMean over axes {axes} of {x} (keepdims must be 1)")
    reduced = {axis % len(x) for axis in axes}
    return tuple(1 if i in reduced else d for i, d in enumerate(x)), int(np.prod(x))


def _broadcast(a: Shape, b: Shape, label: str, refuse: Any) -> Shape:
    """numpy's (and ONNX's multidirectional) broadcast of two shapes, rank <= 2."""
    rank = max(len(a), len(b))
    a, b = (1,) * (rank - len(a)) + a, (1,) * (rank - len(b)) + b
    if rank > _MAX_RANK or any(x != y and 1 not in (x, y) for x, y in zip(a, b, strict=True)):
        raise refuse(f"{label}: shapes {a} and {b} do not broadcast (to rank <= {_MAX_RANK})")
    return tuple(x if y == 1 else y for x, y in zip(a, b, strict=True))
