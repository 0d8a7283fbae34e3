"""Export a trained policy's actor to ONNX, for Unity (ML-Agents reads ONNX), a game engine or
a web page (onnxruntime-web).

    cmdp-export MODEL.zip model.onnx   (training/commands/export.py)

The file holds the actor only (no critic, no optimizer), built node by node from the weights
``agents.models.LeanActor`` copies out of the SB3 zip, so it computes exactly what our
simulations compute. Names:

Input
    ``obs``: float32 (batch, observation size), the observation as the env gives it (115 or
    119 floats for the reaching policy, see ``cmdp_pymunk.observe``; O^e for the evaluation
    policy). No normalisation is applied (our models are trained without any).

Outputs, categorical actions (the reaching policy's ``MultiDiscrete([4, 3, 3])``)
    ``logits``: float32 (batch, 4 + 3 + 3), unnormalised, the sub-actions side by side (a
    softmax over each sub-action's slice gives its probabilities; sample from those for a
    stochastic policy). ``action``: int64 (batch, 3), the argmax of each sub-action (the
    deterministic action): forward {0, 0.3, 0.8, 1}, lateral {-1, 0, 1}, turn {-1, 0, 1}
    as indices.

Outputs, Gaussian actions (the evaluation policy's ``Box(2)``)
    ``mean``: float32 (batch, dim). ``log_std``: float32 (dim,), the same for every row
    (sample ``mean + exp(log_std) * N(0, 1)``). ``action``: float32 (batch, dim), the mean
    clipped to the action space (the deterministic action).

Inputs and outputs, a masked choice (stage 2's ``action = "candidate"``, a MaskablePPO zip)
    ``obs``: float32 (batch, candidates x columns), the candidate rows of
    ``agents.candidates.CandidateView`` side by side; ``mask``: bool (batch, candidates),
    true for a real candidate. ``logits``: float32 (batch, candidates), each row's
    ``scale * V' + linear(row) + residual(row)`` (``agents.candidate_policy.CandidateScorer``;
    a typed model's rows end in the crew type's one-hot, and it adds its per-type term)
    with the masked ones set to -1e8 as sb3-contrib does (a softmax gives the policy's
    probabilities). ``action``: int64 (batch,), the argmax, the candidate it chooses.

The model's metadata (``metadata_props``) records the observation size, the action space and
the source file.

Why a graph built by hand and not ``torch.onnx.export`` (measured with torch 2.13.0): its
default exporter (``dynamo=True``, torch.export-based) needs ``onnxscript``, which is not
installed here (one more dependency for the ``onnx`` extra); its TorchScript exporter
(``dynamo=False``) still works but warns on every call that it "will be removed", and the
package accepts any torch up to 3. The graphs here need only ``onnx``, use a handful of
standard operators (MatMul, Add, the activation, Split/ArgMax or Where/ArgMax), and are
checked against the SB3 policies' own outputs in tests/test_export.py.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

OPSET = 17


def actor_to_onnx(actor, source: str = ""):
    """An ``onnx.ModelProto`` computing the ``LeanActor``'s outputs (see the module doc)."""
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    inits, nodes = [], []

    def const(name, value):
        inits.append(numpy_helper.from_array(np.asarray(value), name))
        return name

    x = "obs"
    for i, (w, b) in enumerate(actor.layers):
        nodes.append(helper.make_node("MatMul", [x, const(f"w{i}", w)], [f"mm{i}"]))
        nodes.append(helper.make_node("Add", [f"mm{i}", const(f"b{i}", b)], [f"pre{i}"]))
        nodes.append(helper.make_node(actor.activation.replace("ReLU", "Relu"), [f"pre{i}"],
                                      [f"h{i}"]))
        x = f"h{i}"
    head = "mean" if actor.gaussian else "logits"
    w, b = actor.action_net
    nodes.append(helper.make_node("MatMul", [x, const("w_action", w)], ["mm_action"]))
    nodes.append(helper.make_node("Add", ["mm_action", const("b_action", b)], [head]))
    batch = "batch"
    outputs = [helper.make_tensor_value_info(head, TensorProto.FLOAT, [batch, w.shape[1]])]
    if actor.gaussian:
        nodes.append(helper.make_node("Identity", [const("log_std_value", actor.log_std)],
                                      ["log_std"]))
        nodes.append(helper.make_node("Max", ["mean", const("low", actor.low)], ["above_low"]))
        nodes.append(helper.make_node("Min", ["above_low", const("high", actor.high)],
                                      ["action"]))
        outputs += [helper.make_tensor_value_info("log_std", TensorProto.FLOAT, [w.shape[1]]),
                    helper.make_tensor_value_info("action", TensorProto.FLOAT,
                                                  [batch, w.shape[1]])]
        space = f"Box({w.shape[1]}, low={actor.low.tolist()}, high={actor.high.tolist()})"
    else:
        parts = [f"logits_{k}" for k in range(len(actor.nvec))]
        nodes.append(helper.make_node("Split", ["logits", const("nvec", np.array(
            actor.nvec, np.int64))], parts, axis=1))
        for k, part in enumerate(parts):
            nodes.append(helper.make_node("ArgMax", [part], [f"action_{k}"], axis=1,
                                          keepdims=1))
        nodes.append(helper.make_node("Concat", [f"action_{k}" for k in range(len(parts))],
                                      ["action"], axis=1))
        outputs.append(helper.make_tensor_value_info("action", TensorProto.INT64,
                                                     [batch, len(actor.nvec)]))
        space = f"MultiDiscrete({actor.nvec})"
    graph = helper.make_graph(
        nodes, "actor",
        [helper.make_tensor_value_info("obs", TensorProto.FLOAT,
                                       [batch, actor.observation_size])],
        outputs, inits)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", OPSET)],
                              producer_name="cmdp-pymunk")
    model.ir_version = 8  # readable by older runtimes too (onnxruntime >= 1.15)
    for key, value in (("observation_size", str(actor.observation_size)),
                       ("action_space", space), ("source", source)):
        model.metadata_props.add(key=key, value=value)
    onnx.checker.check_model(model)
    return model


HUGE_NEG = -1e8  # sb3-contrib's MaskableCategorical: the logit of a masked choice


def candidate_to_onnx(model, source: str = ""):
    """An ``onnx.ModelProto`` of a masked-choice model's actor (a MaskablePPO whose policy is
    ``agents.candidate_policy.CandidateScorerPolicy``): inputs ``obs`` and ``mask``, outputs
    ``logits`` and ``action`` (see the module doc)."""
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    scorer = model.policy.action_net
    columns, cap = int(scorer.columns), int(model.action_space.n)
    first, second = scorer.residual[0], scorer.residual[2]
    if type(scorer.residual[1]).__name__ != "Tanh":
        raise ValueError(f"{source}: the scorer's residual is not Linear-Tanh-Linear; fix: "
                         "export a model trained by cmdp-train stage2 with action = candidate")

    def weights(tensor) -> np.ndarray:
        return tensor.detach().cpu().numpy().astype(np.float32)

    inits = []

    def const(name, value):
        inits.append(numpy_helper.from_array(np.asarray(value), name))
        return name

    n = helper.make_node
    nodes = [
        n("Reshape", ["obs", const("rows_shape", np.array([0, cap, columns], np.int64))],
          ["rows"]),
        # scale * V': V' is column 0 of each row
        n("Gather", ["rows", const("v_column", np.array(0, np.int64))], ["v"], axis=2),
        n("Mul", ["v", const("scale", np.float32(scorer.scale))], ["scaled_v"]),
        # linear(row): (batch, cap, columns) @ (columns, 1)
        n("MatMul", ["rows", const("w_linear", weights(scorer.linear.weight).T)], ["lin3"]),
        # residual(row): Linear, Tanh, Linear
        n("MatMul", ["rows", const("w_res0", weights(first.weight).T)], ["res0_mm"]),
        n("Add", ["res0_mm", const("b_res0", weights(first.bias))], ["res0_pre"]),
        n("Tanh", ["res0_pre"], ["res0"]),
        n("MatMul", ["res0", const("w_res1", weights(second.weight).T)], ["res1_mm"]),
        n("Add", ["res1_mm", const("b_res1", weights(second.bias))], ["res3"]),
        n("Add", ["lin3", "res3"], ["terms3"]),
        n("Squeeze", ["terms3", const("last_axis", np.array([2], np.int64))], ["shared"]),
        *per_type_nodes(scorer, columns, const, weights),
        n("Add", ["scaled_v", "terms"], ["raw_logits"]),
        n("Where", ["mask", "raw_logits", const("huge_neg", np.float32(HUGE_NEG))],
          ["logits"]),
        n("ArgMax", ["logits"], ["action"], axis=1, keepdims=0),
    ]
    batch = "batch"
    graph = helper.make_graph(
        nodes, "candidate_choice",
        [helper.make_tensor_value_info("obs", TensorProto.FLOAT, [batch, cap * columns]),
         helper.make_tensor_value_info("mask", TensorProto.BOOL, [batch, cap])],
        [helper.make_tensor_value_info("logits", TensorProto.FLOAT, [batch, cap]),
         helper.make_tensor_value_info("action", TensorProto.INT64, [batch])], inits)
    proto = helper.make_model(graph, opset_imports=[helper.make_opsetid("", OPSET)],
                              producer_name="cmdp-pymunk")
    proto.ir_version = 8
    for key, value in (("observation_size", str(cap * columns)),
                       ("action_space", f"Discrete({cap}) over {cap} candidates of {columns} "
                                        "columns, masked"), ("source", source)):
        proto.metadata_props.add(key=key, value=value)
    onnx.checker.check_model(proto)
    return proto


def per_type_nodes(scorer, columns: int, const, weights) -> list:
    """The nodes from ``shared`` (batch, cap) to ``terms``: a typed scorer's per-type term
    ``onehot . (W @ row[:-types])`` added (``CandidateScorer``), an untyped one's nothing."""
    from onnx import helper

    n = helper.make_node
    if not scorer.types:
        return [n("Identity", ["shared"], ["terms"])]
    split = columns - scorer.types  # the type columns are the last ones of a row
    return [
        n("Slice", ["rows", const("plain_start", np.array([0], np.int64)),
                    const("plain_end", np.array([split], np.int64)),
                    const("row_axis", np.array([2], np.int64))], ["plain_rows"]),
        n("Slice", ["rows", const("types_start", np.array([split], np.int64)),
                    const("types_end", np.array([columns], np.int64)), "row_axis"],
          ["onehot"]),
        n("MatMul", ["plain_rows", const("w_per_type", weights(scorer.per_type.weight).T)],
          ["per_type_all"]),
        n("Mul", ["per_type_all", "onehot"], ["per_type_own"]),
        n("ReduceSum", ["per_type_own", "row_axis"], ["per_type"], keepdims=0),
        n("Add", ["shared", "per_type"], ["terms"]),
    ]


def export(model_path: str | Path, onnx_path: str | Path) -> Path:
    """Write the actor of the SB3 zip at ``model_path`` to ``onnx_path`` (atomically): a PPO
    (reaching policy, stage-2 desired position) or a MaskablePPO masked choice."""
    from agents.candidates import is_candidate_model, load_candidate_model
    from agents.models import LeanActor

    if is_candidate_model(model_path):
        proto = candidate_to_onnx(load_candidate_model(model_path),
                                  source=Path(model_path).name)
    else:
        proto = actor_to_onnx(LeanActor.from_zip(model_path), source=Path(model_path).name)
    onnx_path = Path(onnx_path)
    onnx_path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=onnx_path.parent, suffix=".onnx.tmp")
    with os.fdopen(fd, "wb") as f:
        f.write(proto.SerializeToString())
    os.replace(tmp, onnx_path)
    return onnx_path
