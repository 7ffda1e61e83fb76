"""The exported tip model of the lab workflow in a control loop (docs/guide/lab-workflow.md).

Every frame (one sample, 50 ms at 20 Hz) the loop hands the model the tendon tensions it commands
and gets the tip position one frame ahead. Here the tensions come from a recording and the model
runs free (its own predictions are fed back, as an internal model in a controller would be run
over its horizon); the measured positions are only compared with. It steps the same model twice:

* the ONNX file written by ``softrnn export --onnx`` in ONNX Runtime (no softrnn needed), and
* softrnn's compiled engine (``softrnn.learned.node.engine.NodeStepper``) on the model folder,

and prints the RMS error against the recording and the time per step (median and 99th percentile).

    python examples/lab_control_loop.py tip.onnx lab.h5 [--model models/tip] [--start 0.6]
"""

import argparse
import json
import time

import numpy as np


def onnx_stepper(path):
    """(fill, step) for the ONNX file: ``fill(positions (H, 3), tensions (H, m))`` loads the last H
    recorded samples, ``step(position (3,), tensions (m,))`` appends one and returns the tip's next
    position (3,) [m]; one ONNX Runtime session on one thread, a rolling window updated in place."""
    import onnxruntime as ort

    options = ort.SessionOptions()
    options.intra_op_num_threads = 1
    options.inter_op_num_threads = 1
    options.execution_mode = ort.ExecutionMode.ORT_SEQUENTIAL
    session = ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])
    meta = session.get_modelmeta().custom_metadata_map
    H, P, W = (json.loads(meta[k]) for k in ("history", "pose_features", "wrench_features"))
    poses = np.zeros((1, H, P), np.float32)          # the tip's x, y, z per step, oldest first
    inputs = np.zeros((1, H, W), np.float32)         # the tensions per step (the graph's 'wrenches')
    feeds = {"poses": poses, "wrenches": inputs}

    def fill(positions, tensions):
        poses[0], inputs[0] = positions[-H:], tensions[-H:]
        return session.run(None, feeds)[0][0]

    def step(position, tensions):
        poses[0, :-1] = poses[0, 1:]
        poses[0, -1] = position
        inputs[0, :-1] = inputs[0, 1:]
        inputs[0, -1] = tensions
        return session.run(None, feeds)[0][0]
    return fill, step


def engine_stepper(folder):
    """The same with softrnn's compiled engine (``NodeStepper``) on the model folder."""
    from softrnn.learned.node import load_model
    from softrnn.learned.node.engine import NodeStepper

    stepper = NodeStepper(load_model(folder))
    H = stepper.history
    return (lambda positions, tensions: stepper.reset(positions[-H:], tensions[-H:])), stepper.step


def free_run(fill, step, positions, tensions, start):
    """Run free from the recorded window ending at sample ``start``: (predicted (T', 3) [m] for the
    samples start + 1 ..., the time of each step [s])."""
    nxt = np.array(fill(positions[:start + 1], tensions[:start + 1]))
    out, times = [nxt], []
    for k in range(start + 1, len(positions) - 1):
        t0 = time.perf_counter()
        nxt = np.array(step(nxt, tensions[k]))        # this frame's tensions -> the next frame's tip (a copy)
        times.append(time.perf_counter() - t0)
        out.append(nxt)
    return np.array(out), np.array(times)


def main():
    from softrnn.io import read_dataset

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("onnx", help="the file written by softrnn export --onnx")
    ap.add_argument("data", help="the imported recording (softrnn import-csv)")
    ap.add_argument("--model", help="the model folder too: also step softrnn's compiled engine")
    ap.add_argument("--start", type=float, default=0.6, help="where the free run starts, as a fraction of the record")
    args = ap.parse_args()
    d = read_dataset(args.data)
    positions, tensions = d.positions[:, 0].astype(np.float32), d.actuation.astype(np.float32)
    start = int(args.start * d.n_samples)
    runs = [("ONNX Runtime", *onnx_stepper(args.onnx))]
    if args.model:
        runs.append(("compiled engine", *engine_stepper(args.model)))
    for name, fill, step in runs:
        predicted, times = free_run(fill, step, positions, tensions, start)
        ref = positions[start + 1:start + 1 + len(predicted)]
        rmse = np.sqrt(np.mean((predicted - ref) ** 2)) * 1e3
        print(f"{name}: {len(times)} steps free running from t = {d.time[start]:g} s, RMSE {rmse:.3g} mm; "
              f"per step {np.median(times) * 1e6:.1f} us median, {np.percentile(times, 99) * 1e6:.1f} us p99 "
              f"(the frame is {d.dt * 1e3:g} ms)")


if __name__ == "__main__":
    main()
