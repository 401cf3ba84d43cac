"""What `artro fit` writes (docs/FIT.md): the fitted robot (the description with its `fitted:`
section, the nominal untouched), and a report: a Markdown table of the fields (value, σ, what
the recording told, the truth where the recording was simulated) and a PNG of recorded against
simulated traces before and after the fit."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from app.analysis.fit_sensors import NOISE
from app.analysis.identify_record import Recording
from app.robots.fitted import Fitted, write_fitted
from app.robots.model import RobotModel
from app.study import fit_space
from app.study.fit_result import Fit
from app.worlds.variations import parse_variation

UNITS = {
    "latency_ms": "ms",
    "tilt_x_deg": "°",
    "tilt_y_deg": "°",
    "imu_tilt_x_deg": "°",
    "imu_tilt_y_deg": "°",
    "gyro_bias_deg_s": "°/s",
}
CHANNEL_UNITS = {"gyro": "rad/s", "accel": "m/s²", "fsr": "N", "present": "rad"}


def fitted_robot(
    robot: RobotModel, result: Fit, recording: Recording, source: Path, out: Path
) -> None:
    """Write the fitted robot: the description as it is, with `fitted:` (the nominal variation
    when the fit did not converge)."""
    fitted = Fitted(
        variation=result.variation.to_text(),
        sigma={k: round(v, 6) for k, v in result.sigma.items()},
        identified=tuple(k for k, ok in result.identified.items() if ok and result.converged),
        recording=str(source),
        routine=recording.routine,
    )
    write_fitted(robot.description.model_copy(update={"fitted": None}), fitted, out)


def summary(result: Fit, recording: Recording) -> dict[str, Any]:
    """The fit as plain data (`--json`)."""
    truth = (
        fit_space.truth_values(parse_variation(recording.truth))
        if recording.truth is not None
        else None
    )
    return {
        "converged": result.converged,
        "why_not": result.why_not,
        "variation": result.variation.to_text(),
        "fields": {
            k: {"value": v, "sigma": result.sigma[k], "identified": result.identified[k]}
            | ({"truth": truth[k]} if truth else {})
            for k, v in result.values.items()
        },
        "correlated": [list(c) for c in result.correlated],
        "flat": result.flat,
        "still": result.still,
        "loss": {"nominal": result.loss_nominal, "fitted": result.loss_fit},
        "rms": {"nominal": result.rms_nominal, "fitted": result.rms_fit},
        "noise_ratio": result.noise_ratio(),
        "replays": result.evaluations,
        "source": recording.source,
    }


def write_report(result: Fit, recording: Recording, folder: Path, robot: str, fitted: Path) -> Path:
    """report.md and traces.png in `folder`; returns the Markdown's path."""
    folder.mkdir(parents=True, exist_ok=True)
    data = summary(result, recording)
    lines = [f"# Fit of {recording.routine} on {robot!r} ({recording.source})", "", "## Fields", ""]
    truth = recording.truth is not None
    lines.append("| field | fitted | ±1σ | told by the recording |" + (" truth |" if truth else ""))
    lines.append("|---|---|---|---|" + ("---|" if truth else ""))
    for name, f in data["fields"].items():
        unit = UNITS.get(name, "")
        told = "yes" if f["identified"] else why_not_told(name, result)
        row = f"| {name} | {f['value']:.4g} {unit} | {f['sigma']:.2g} | {told} |"
        lines.append(row + (f" {f['truth']:.4g} |" if truth else ""))
    state = (
        "converged" if result.converged else f"did not converge: {result.why_not}; the nominal kept"
    )
    lines += [
        "",
        f"The fit {state}, after {result.evaluations} replays; loss {result.loss_nominal:.4f}"
        f" (nominal) → {result.loss_fit:.4f}.",
        "",
        "σ from the loss's curvature (Gauss-Newton on central differences, the residuals' "
        "autocorrelation counted): a lower bound where the contacts make the loss rough.",
        "",
        "## Residuals",
        "",
        "| channel | nominal rms | fitted rms | fitted / sensor noise |",
        "|---|---|---|---|",
    ]
    for c, v in result.rms_fit.items():
        lines.append(
            f"| {c} ({CHANNEL_UNITS[c]}) | {result.rms_nominal[c]:.4g} | {v:.4g} | "
            f"{v / NOISE[c]:.1f} |"
        )
    lines += [
        "",
        f"Fitted variation: `{data['variation'] or 'nominal'}`",
        "",
        f"Fitted robot: `{fitted}`; tune on it: `artro tune --robot {fitted}`; bench it: "
        f"`artro bench robust --robot {fitted}`.",
        "",
        "![traces](traces.png)",
        "",
    ]
    path = folder / "report.md"
    path.write_text("\n".join(lines), encoding="utf-8")
    plot_traces(result, recording, folder / "traces.png")
    return path


def why_not_told(name: str, result: Fit) -> str:
    if name in result.still:
        return f"no: {result.still[name]}"
    if name in result.flat:
        return "no: the recording barely moves it (flat)"
    partners = [b if a == name else a for a, b, _ in result.correlated if name in (a, b)]
    if partners:
        return f"no: moves the traces as {', '.join(partners)} does"
    return "no: σ wider than the precision a fit must reach"


def plot_traces(result: Fit, recording: Recording, path: Path) -> None:
    """Recorded against the nominal's and the fit's replay: the gyro's roll rate, the
    accelerometer's z, the left foot's force, over the weight shifts and the forward walk."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from app.analysis.identify_record import traces_of

    recorded = traces_of(recording)
    spans = {s.name: s for s in recording.segments}
    windows = [w for w in ("weight shifts", "forward") if w in spans]
    channels = [
        ("gyro x (rad/s)", lambda t: t.gyro[:, 0]),
        ("accel z (m/s²)", lambda t: t.accel[:, 2]),
        ("left foot force (N)", lambda t: t.fsr[:, :4].sum(1)),
    ]
    fig, axes = plt.subplots(
        len(channels), len(windows), figsize=(6 * len(windows), 7), squeeze=False
    )
    at = recorded.positions  # the replays' rows are the recording's (`fit.aligned`)
    for col, name in enumerate(windows):
        span = spans[name]
        first = span.start + span.frames // 3
        rows = (at >= first) & (at < first + 150)
        t = at[rows] * recording.frame_s
        for row, (label, get) in enumerate(channels):
            ax = axes[row][col]
            ax.plot(t, get(recorded)[rows], color="black", lw=1.5, label="recorded")
            ax.plot(t, get(result.replay_nominal)[rows], color="tab:red", lw=1, label="nominal")
            ax.plot(
                t, get(result.replay_fit)[rows], color="tab:blue", lw=1, ls="--", label="fitted"
            )
            ax.set_ylabel(label)
            if row == 0:
                ax.set_title(name)
            if row == len(channels) - 1:
                ax.set_xlabel("time in the routine (s)")
    axes[0][0].legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
