"""Plots and a Markdown summary of an identification (``orthoglide-ident report``).

- ``torques.png``: measured g_τ·v_τ against the model torque IDM·χ̂ per joint on a record not used
  for identification (the paper's Fig. 5); without a validation bag, on the last identification
  record, and the title says so.
- ``parameters.png``: relative standard deviation (%σ) of every identified quantity, base and
  essential side by side when both exist.
- ``summary.md``: the tables of ``IdentificationResult.to_text()`` in Markdown, with the figures.
Matplotlib runs headless (Agg).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from orthoglide_ident.identify.validate.cross_validation import ValidationResult, cross_validate
from orthoglide_ident.results import IdentificationResult


def validation_for_plot(res: IdentificationResult) -> tuple[ValidationResult | None, bool]:
    """The validation record to plot, and whether it is a true cross-validation."""
    if res.validation_details:
        return res.validation_details[0], True
    if not res.observations:
        return None, False
    block = res.observations[-1]
    chi = np.array([p.value for p in res.parameters]) if res.observations_chi is None \
        else np.asarray(res.observations_chi)
    if chi.shape[0] != block.W.shape[2]:
        return None, False
    g = np.array([g.value for g in res.drive_gains])
    m = block.payload_mass
    if block.loaded and res.drive_gains_given and res.payloads:  # the masses estimated
        m = next((p.value for p in res.payloads if block.source in p.bags), m)
    return cross_validate(block, chi, g, m, np.asarray(res.residual_rms),
                          joint_names=tuple(res.joint_names)), False


def plot_torques(res: IdentificationResult, path: Path, window_s: float = 10.0) -> bool:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    val, crossed = validation_for_plot(res)
    if val is None:
        return False
    n_j = len(res.joint_names)
    units = res.effort_units or ["N"] * n_j
    fig, axes = plt.subplots(n_j, 1, figsize=(10, 2 + 2 * n_j), sharex=True, squeeze=False)
    axes = axes[:, 0]
    # a readable window (the figures in the titles are over the whole record)
    w = (val.t >= val.t[0]) & (val.t <= val.t[0] + window_s)
    for j, ax in enumerate(axes):
        ax.plot(val.t[w], val.tau_measured[j][w], lw=0.9, label="measured  g_τ·v_τ")
        ax.plot(val.t[w], val.tau_model[j][w], lw=0.9, ls="--", label="model  IDM·χ̂")
        ax.set_ylabel(f"{res.joint_names[j]} ({units[j]})")
        note = val.notes[j] if val.notes else ""
        ax.set_title(f"{res.joint_names[j]}: " + (note if note else
                     f"residual rms {val.residual_rms[j]:.3g} {units[j]} "
                     f"({100 * val.relative_error[j]:.1f} %) over the record"), fontsize=9)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("time (s)")
    kind = "cross-validation" if crossed else "identification record (not cross-validated)"
    fig.suptitle(f"Measured and model forces, {kind}: {Path(val.source).name}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


def plot_parameters(res: IdentificationResult, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [f"g_tau {g.name}" for g in res.drive_gains if not res.drive_gains_given]
    base = [g.rel_std for g in res.drive_gains if not res.drive_gains_given]
    names += [p.name for p in res.parameters]
    base += [p.rel_std for p in res.parameters]
    ess = None
    if res.essential is not None:
        e = {f"g_tau {g.name}": g.rel_std for g in res.essential.drive_gains}
        e.update({p.name: p.rel_std for p in res.essential.parameters})
        ess = [e.get(n, np.nan) for n in names]
    pct = 100 * np.array([x if math.isfinite(x) else np.nan for x in base])
    fig, ax = plt.subplots(figsize=(max(8, 0.22 * len(names)), 5))
    x = np.arange(len(names))
    w = 0.4 if ess is not None else 0.8
    ax.bar(x - (w / 2 if ess is not None else 0), pct, width=w, label="base parameters")
    if ess is not None:
        ax.bar(x + w / 2, 100 * np.array(ess, dtype=float), width=w, label="essential parameters")
    ax.set_yscale("log")
    ax.set_xticks(x)
    ax.set_xticklabels(names, rotation=90, fontsize=7)
    ax.set_ylabel("%σ (relative standard deviation, %)")
    ax.set_title(f"IDIM-{res.method.upper()}: relative standard deviations")
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_summary(res: IdentificationResult, path: Path, figures: list[str]) -> None:
    lines = [f"# {res.robot.capitalize()} identification — IDIM-{res.method.upper()}", ""]
    lines += ["Bags: " + ", ".join(f"`{b}`" for b in res.bags), ""]
    lines += [f"## Drive gains ({res._units(res.gain_units, 'N/A')})"
              + (" — given" if res.drive_gains_given else ""), "",
              "| joint | value | %σ |" + (" essential | %σ |" if res.essential else ""),
              "|---|---:|---:|" + ("---:|---:|" if res.essential else "")]
    eg = {g.name: g for g in res.essential.drive_gains} if res.essential else {}
    for g in res.drive_gains:
        if not g.determined:
            lines.append(f"| {g.name} | not determined: {g.reason} | |")
            continue
        row = f"| {g.name} | {g.value:.6g} | {100 * g.rel_std:.3g} |"
        if res.essential:
            row += f" {eg[g.name].value:.6g} | {100 * eg[g.name].rel_std:.3g} |"
        lines.append(row)
    lines += ["", "## Base parameters", "",
              "| parameter | value | %σ |" + (" essential | %σ |" if res.essential else "")
              + " expression |",
              "|---|---:|---:|" + ("---:|---:|" if res.essential else "") + "---|"]
    ep = {p.name: p for p in res.essential.parameters} if res.essential else {}
    for p in res.parameters:
        rel = f"{100 * p.rel_std:.3g}" if math.isfinite(p.rel_std) else "—"
        row = f"| {p.name} | {p.value:.6g} | {rel} |"
        if res.essential:
            e = ep.get(p.name)
            row += f" {e.value:.6g} | {100 * e.rel_std:.3g} |" if e else " — | |"
        lines.append(row + f" {p.expression} |")
    lines += [""]
    for pm in res.payloads:
        kind = "known (weighed)" if pm.known else f"estimated (tagged {pm.tagged:g} kg)"
        lines.append(f"- payload mass m_7: **{pm.value:.5g} kg** ± {100 * pm.rel_std:.3g} %, "
                     f"{kind}")
    lines.append(f"- condition number of the scaled observation matrix: {res.condition_number:.4g}")
    lines.append(f"- residual rms per joint ({res._units(res.effort_units, 'N')}): " + ", ".join(
        f"{j} {r:.4g}" if math.isfinite(r) else f"{j} —"
        for j, r in zip(res.joint_names, res.residual_rms)))
    for v in res.validation:
        lines.append(f"- cross-validation on `{v.bag}`: " + v.figures(res.effort_units, "—"))
    for w in res.warnings:
        lines.append(f"- warning: {w}")
    lines.append("")
    for f in figures:
        lines += [f"![{f}]({f})", ""]
    path.write_text("\n".join(lines))


def write_report(res: IdentificationResult, out_dir: str | Path) -> list[Path]:
    """Write torques.png, parameters.png, summary.md and result.json into ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    figures: list[str] = []
    if plot_torques(res, out / "torques.png"):
        figures.append("torques.png")
        written.append(out / "torques.png")
    plot_parameters(res, out / "parameters.png")
    figures.append("parameters.png")
    written.append(out / "parameters.png")
    write_summary(res, out / "summary.md", figures)
    written.append(out / "summary.md")
    res.write_json(out / "result.json")
    written.append(out / "result.json")
    return written
