"""softrnn export MODEL --onnx model.onnx [--torchscript model.pt]: a node model with its
normalisation as one file for a control loop (physical windows in, the next position [m] out)."""

from pathlib import Path

from ..errors import bad
from ..files import prepare_output

NAME = "export"
HELP = ("export a trained node model, normalisation included, to ONNX (ONNX Runtime, C++ or Python) and/or "
        "TorchScript (libtorch): physical input windows in, the node's next position [m] out (docs/export.md)")


def add_args(p):
    p.add_argument("model", help="a model folder written by 'softrnn train'")
    p.add_argument("--onnx", default=None, metavar="PATH", help="write the ONNX file here (e.g. model.onnx)")
    p.add_argument("--torchscript", default=None, metavar="PATH",
                   help="write the TorchScript file here (e.g. model.pt)")
    p.add_argument("--opset", type=int, default=None, help="ONNX opset, 11 to 20 (default: 17)")
    p.add_argument("--static-batch", action="store_true",
                   help="fix the ONNX batch dimension to 1 (default: any batch size)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace the --onnx and --torchscript files if they exist (default: refuse)")


def _targets(args) -> dict:
    """{'onnx': Path, 'torchscript': Path} of the files asked for, checked before anything is written."""
    from ..errors import SoftrnnInputError

    targets = {k: Path(v) for k, v in (("onnx", args.onnx), ("torchscript", args.torchscript)) if v}
    if not targets:
        raise SoftrnnInputError("nothing to write: give at least one of --onnx PATH and --torchscript PATH")
    if "onnx" not in targets and (args.opset is not None or args.static_batch):
        raise bad("--opset" if args.opset is not None else "--static-batch",
                  args.opset if args.opset is not None else True, "used with --onnx PATH only (ONNX options)")
    if len(targets) == 2 and targets["onnx"].resolve() == targets["torchscript"].resolve():
        raise bad("--torchscript", args.torchscript, "a path other than --onnx's (both would write one file)")
    model_dir = Path(args.model).resolve()
    for kind, path in targets.items():
        if path.is_dir():
            raise bad(f"--{kind}", str(path), "a file path, not a folder")
        if model_dir in path.resolve().parents:
            raise bad(f"--{kind}", str(path), "a path outside the model folder (a foreign file there would stop "
                                              "'softrnn train' from replacing the model)")
        prepare_output(path, f"--{kind}", overwrite=args.overwrite)
    return targets


def run(args) -> int:
    from ..learned.node.artifact import load_model
    from ..learned.node.export import OUTPUT_NAME as OUTPUT
    from ..learned.node.export import export_onnx, export_torchscript

    targets = _targets(args)
    model = load_model(args.model)
    c = model.config
    shapes = f"poses (B, {c.history}, {c.pose_features}) [m" + (", 1]" if model.spec.per_node == 7 else "]")
    if c.wrench_features:
        shapes += f", wrenches (B, {c.history}, {c.wrench_features}) [N" + (", N m]" if c.wrench_features == 6 else "]")
    if "onnx" in targets:
        export_onnx(model, targets["onnx"], opset=args.opset, dynamic_batch=not args.static_batch)
        print(f"export: wrote {targets['onnx']} (ONNX; {shapes} -> {OUTPUT} (B, 3) [m])")
    if "torchscript" in targets:
        export_torchscript(model, targets["torchscript"])
        print(f"export: wrote {targets['torchscript']} (TorchScript; {shapes} -> {OUTPUT} (B, 3) [m])")
    return 0
