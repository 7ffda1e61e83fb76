"""The reproduction report's sections on the paper's studies and experiments (``report.md``,
docs/report-format.md): the Fig. 13 and Fig. 14 studies, the magnetic experiment (its static model
and calibration) and the closed-loop control; ``report.render_markdown`` puts them together."""


def fig13_lines(f: dict | None) -> list[str]:
    """The static solver's solve times (Fig. 13): against tolerance and against the step count."""
    if not f:
        return []
    s = f["summary"]
    tol, nodes = s["tolerance_sweep"], s["node_sweep"]
    lines = ["", "## Static Cosserat solver: solve time (paper Fig. 13)", "",
             f"Mean +- std of {s['repetitions']} solves per point; rows: guess error "
             f"{', '.join(f'{100 * e:g} %' for e in s['guess_errors'])}. Paper: "
             f"{s['paper']['solve_time_ms'][0]:g}-{s['paper']['solve_time_ms'][1]:g} ms per solve "
             f"({s['paper']['bandwidth_hz'][0]:g}-{s['paper']['bandwidth_hz'][1]:g} Hz) on an i7 laptop.", "",
             f"![fig13](figures/{f['figure']})", "",
             f"| N = {tol['n_steps']}, tolerance E | " + " | ".join(f"{t:g}" for t in tol["tolerances"]) + " |",
             "|---|" + "---|" * len(tol["tolerances"])]
    for i, e in enumerate(s["guess_errors"]):
        lines.append(f"| guess error {100 * e:g} % [ms] | " + " | ".join(
            f"{tol['mean_ms'][k][i]:.3f} +- {tol['std_ms'][k][i]:.3f}" for k in range(len(tol["tolerances"]))) + " |")
    lines += ["", f"| E = {nodes['tol']:g}, steps N | " + " | ".join(str(n) for n in nodes["n_steps"]) + " |",
              "|---|" + "---|" * len(nodes["n_steps"])]
    for i, e in enumerate(s["guess_errors"]):
        lines.append(f"| guess error {100 * e:g} % [ms] | " + " | ".join(
            f"{nodes['mean_ms'][k][i]:.3f} +- {nodes['std_ms'][k][i]:.3f}"
            for k in range(len(nodes["n_steps"]))) + " |")
    return lines


def fig14_lines(f: dict | None) -> list[str]:
    """The Fig. 14 study: the best regions beside the paper's, and the trends."""
    if not f:
        return []
    lines = ["", f"## LSTM units x history (paper Fig. 14): {f['case']}, node {f['node']}", "",
             f"![fig14](figures/{f['figure']})", ""]
    for key, what in (("bandwidth", "compiled stepper bandwidth"), ("torch_bandwidth", "eager PyTorch bandwidth"),
                      ("rms_error", "one-step RMS error")):
        r = (f.get("regions") or {}).get(key)
        if not r:
            continue
        pts = ", ".join(f"({u}, {h})" for u, h in r["points"])
        p = r["paper"]
        lines.append(f"- {what}: best region (units, history) {pts}; the paper's: units {p['lstm_units'][0]}-"
                     f"{p['lstm_units'][1]}, history {p['history'][0]}-{p['history'][1]} "
                     f"({100 * r['fraction_in_paper_region']:.0f} % of ours inside it)")
    t = f.get("trends") or {}
    lines.append(f"- trends from the smallest to the largest grid value: bandwidth {_pct(t.get('bandwidth_vs_units'))} "
                 f"with units, {_pct(t.get('bandwidth_vs_history'))} with history; RMS error "
                 f"{_pct(t.get('rms_error_vs_units'))} with units, {_pct(t.get('rms_error_vs_history'))} with history")
    return lines


def _pct(x) -> str:
    """A fraction as a signed percentage; "n/a" for None."""
    return "n/a" if x is None else f"{100 * x:+.0f} %"


def magnetic_lines(m: dict | None) -> list[str]:
    """The magnetic experiment: Table 1 beside the paper's, and the bending axis."""
    if not m:
        return []
    axes = "xyz"
    lines = ["", "## The magnetic experiment, simulated (paper section 5, Table 1)", "",
             "Errors (max, mean) in degrees about x, y, z on the last 40 % of the samples: the LSTM one step ahead "
             "from the measured history (as the paper), the LSTM free running, the static Cosserat model from the "
             "coil currents, and the dynamic Cosserat model calibrated to the training span's camera record, from "
             "the coil currents alone. The simulated robot's parameters are perturbed from the nominal ones (see "
             "docs/magnetic-format.md).", "",
             "| magnet | model | x | y | z | paper x | paper y | paper z |", "|---|---|---|---|---|---|---|---|"]
    paper = m.get("paper", {})
    for magnet in ("distal", "proximal"):
        for key, label, pkey in (("rnn", "LSTM (one step)", "rnn"), ("rnn_free_running", "LSTM (free running)", None),
                                 ("cosserat", "static Cosserat", "cosserat"),
                                 ("calibrated", "calibrated dynamic Cosserat", None)):
            row = m[magnet].get(key)
            if row is None:
                continue
            p = paper.get(magnet, {}).get(pkey) if pkey else None
            cells = [f"{a:.2f}, {b:.2f}" for a, b in row]
            pcells = [f"{a:.2f}, {b:.2f}" for a, b in p] if p else ["", "", ""]
            lines.append(f"| {magnet} | {label} | " + " | ".join(cells) + " | " + " | ".join(pcells) + " |")
    bend = m.get("bending_axis")
    if bend is not None:
        name = axes[bend] if isinstance(bend, int) else str(bend)
        wins = m.get("lstm_beats_static_on_bending_axis") or {}
        lines += ["", f"Bending axis: {name}. The LSTM's mean error is below the static model's there: distal "
                      f"{wins.get('distal')}, proximal {wins.get('proximal')}."]
        best = m.get("best_on_bending_axis")
        if best:
            names = {"rnn": "LSTM (one step)", "rnn_free_running": "LSTM (free running)", "cosserat": "static Cosserat",
                     "calibrated": "calibrated dynamic Cosserat"}
            lines += ["", "Lowest error about the bending axis: " + "; ".join(
                f"{magnet} max {names.get(b['max'], b['max'])}, mean {names.get(b['mean'], b['mean'])}"
                for magnet, b in best.items()) + "."]
    lines += _calibration_lines(m.get("calibration"))
    lines += ["", "![fig12](figures/fig12.png)"]
    return lines


def control_lines(c: dict | None) -> list[str]:
    """Closed-loop control: each controller on each reference, the robustness runs and the goals."""
    if not c:
        return []
    st = c["settings"]
    plant = st["plant"]
    lines = ["", "## Closed-loop control of the magnetic rod (beyond the paper)", "",
             f"The experiment's robot (stiffness x{plant['stiffness']:g}, remanence x{plant['remanence']:g}, "
             f"damping x{plant['damping']:g}) measured by the camera with its noise at {plant['rate']:g} Hz; "
             f"{st['duration']:g} s per run; tracking error of the distal magnet's true orientation (about x and y) "
             f"in degrees. mpc-learned plans on a NARX network identified open loop on the robot "
             f"({st['identify']:g} s) and trained in {c['model'].get('seconds', 0):.0f} s.", "",
             "| controller | reference | RMS | max | limit violations | ms per frame (median, p99) | stable |",
             "|---|---|---|---|---|---|---|"]
    rows = [(ctrl, ref, c[ctrl][ref]) for ctrl in ("static-inverse", "mpc-learned") for ref in st["references"]]
    rows += [(f"mpc-learned, plant {p}", ref, c["robustness"][p][ref]) for p in c["robustness"]
             for ref in st["references"]]
    for name, ref, r in rows:
        lines.append(f"| {name} | {ref} | {r['rms_deg']:.3f} | {r['max_deg']:.2f} | {r['limit_violations']} | "
                     f"{r['compute_ms_median']:.3f}, {r['compute_ms_p99']:.3f} | {r['stable']} |")
    lines += _physics_lines(c.get("mpc-physics"), st)
    lines += ["", "Goals (reported, not asserted): " + "; ".join(
        f"{name.replace('_', ' ')}: {'met' if g['met'] else 'MISSED'} ({_shown(g['value'])}; goal {g['goal']})"
        for name, g in c["goals"].items()) + ".", "", f"![control]({c['figure']})"]
    return lines


def _physics_lines(p: dict | None, st: dict) -> list[str]:
    """mpc-physics over the first seconds of each reference, beside the other two over those frames."""
    if not p:
        return []
    lines = ["", f"mpc-physics (the same MPC on the nominal dynamic simulator; far from real time) over the first "
                 f"{st.get('physics_duration', 0):g} s of each reference, RMS [deg] of the three controllers over "
                 f"those frames:", "",
             "| reference | static-inverse | mpc-learned | mpc-physics | mpc-physics ms per frame (median, p99) | "
             "limit violations |", "|---|---|---|---|---|---|"]
    for ref, r in p.items():
        same = r["same_frames_rms_deg"]
        rms = " | ".join(f"{same[k]:.3f}" for k in ("static-inverse", "mpc-learned", "mpc-physics"))
        lines.append(f"| {ref} | {rms} | {r['compute_ms_median']:.0f}, {r['compute_ms_p99']:.0f} | "
                     f"{r['limit_violations']} |")
    return lines


def _shown(value) -> str:
    if isinstance(value, dict):
        return ", ".join(f"{k} {_shown(v)}" for k, v in value.items())
    if isinstance(value, float):
        return f"{value:.3g}"
    return str(value)


def _calibration_lines(c: dict | None) -> list[str]:
    """The magnetic calibration: fitted factors beside the real robot's, time and trials."""
    if not c:
        return []
    lines = ["", "### Calibration of the dynamic model (softrnn.calibration)", "",
             f"Fitted to {c['samples']} samples ({c['span_s'][1]:.1f} s) of the training span: {c['measured']}. "
             f"{c['trials']} simulations ({c['failed_trials']} failed, {c.get('cached_trials', 0)} reused), "
             f"{c['seconds']:.1f} s on {c['workers']} worker(s).", "",
             "| factor | fitted | std error | real robot | error |", "|---|---|---|---|---|"]
    for name, p in c["parameters"].items():
        truth = p.get("truth")
        lines.append(f"| {name} ({p['factor_of']}) | {p['fitted']:.4f} | {p['std_error']:.4f} | "
                     + (f"{truth:g} | {p['error_pct']:+.2f} % |" if truth is not None else "- | - |"))
    goals = c.get("goals")
    if goals:
        lines += ["", "Goals: " + ", ".join(f"{k.replace('_', ' ')}: {'met' if v else 'MISSED'}"
                                           for k, v in goals.items()) + "."]
    for warning in c.get("not_identifiable") or []:
        lines.append(f"Not identifiable: {warning}.")
    return lines
