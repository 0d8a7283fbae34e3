"""Export a trained policy's actor to ONNX, for Unity (ML-Agents reads ONNX), a game engine or
a web page (onnxruntime-web).

    cmdp-export MODEL.zip model.onnx

The graph, its inputs and outputs are ``training/onnx_export.py``'s documentation.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    import cmdp_pymunk

    parser = argparse.ArgumentParser(prog="cmdp-export",
                                     description=" ".join(__doc__.split("\n\n")[0].split()))
    cmdp_pymunk.add_version_flag(parser)
    parser.add_argument("model", type=Path, help="a stable-baselines3 PPO .zip, or a masked-choice "
                        "MaskablePPO .zip (cmdp-train stage2 with action = candidate)")
    parser.add_argument("onnx", type=Path, help="the .onnx file to write")
    args = parser.parse_args(argv)
    if not args.model.is_file():
        print(f"cmdp-export: {args.model}: no such model file; give a .zip saved by "
              "stable-baselines3 (e.g. models/stage1_reaching.zip)", file=sys.stderr)
        return 2
    from training.onnx_export import export

    try:
        out = export(args.model, args.onnx)
    except ValueError as err:
        print(f"cmdp-export: {err}", file=sys.stderr)
        return 2
    print(f"cmdp-export: wrote {out} (input 'obs'; outputs: see training/onnx_export.py)")
    return 0


def entry_point() -> None:
    sys.exit(main())


if __name__ == "__main__":
    entry_point()
