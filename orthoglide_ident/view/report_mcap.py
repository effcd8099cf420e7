"""``orthoglide-ident report ... --mcap FILE``: the identification's plots as an MCAP file that
Foxglove or Lichtblick open by drag and drop (JSON channels with JSON schemas, foxglove-sdk).

Channels (schemas in view/schemas.py, the same as the live viewer's where they show the same thing):

- ``/orthoglide/report/convergence``: the drive gains ± σ with the first τ seconds of every
  record (view/convergence.py), one message per step;
- ``/orthoglide/report/forces``: per joint the measured force g_τ v_τ, the model's W χ̂ + W_kl m_7
  and their difference, at every decimated row of the record report.py plots (the validation
  record, else the last identification record: metadata ``forces_record`` says which);
- ``/orthoglide/identified_parameters``: the result (gains ± σ, base parameters with %σ), once.

Time axis: log times are seconds from the start of a record: τ for the convergence, the row's
instant in its record for the forces, the longest record's end for the result. The
``orthoglide_report`` metadata record says which records and which durations.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.identify.options import KEY_GROUP, IdentifyOptions
from orthoglide_ident.identify.solve.methods import METHODS
from orthoglide_ident.identify.solve.tls import ExcitationLimits
from orthoglide_ident.report import validation_for_plot
from orthoglide_ident.results import IdentificationResult
from orthoglide_ident.view import schemas
from orthoglide_ident.view.convergence import gain_convergence, record_seconds

NS = 1_000_000_000
CHANNELS = (schemas.REPORT_CONVERGENCE, schemas.REPORT_FORCES, schemas.IDENTIFIED)


def _limits(options: dict, nominal_gains: list[float]) -> ExcitationLimits:
    """The identification's excitation limits (its options as recorded in the result)."""
    opts = IdentifyOptions.of(**{k: v for k, v in options.items() if k in KEY_GROUP})
    return opts.solve.limits(nominal_gains)


def report_messages(
    res: IdentificationResult,
) -> tuple[dict[str, list[tuple[int, dict]]], dict[str, str]]:
    """Per channel (log time ns, message) in time order, and the metadata record's entries."""
    opts = {} if res.diagnostics is None else res.diagnostics.options
    joints = list(res.joint_names)
    end = max((record_seconds(o) for o in res.observations), default=0.0)
    out: dict[str, list[tuple[int, dict]]] = {c: [] for c in CHANNELS}
    method = METHODS.get(res.method)
    if method is not None and method.gains_converge and res.observations:
        for p in gain_convergence(res.observations, weighting=opts.get("weighting", True),
                                  noisy_columns=opts.get("tls_noisy_columns", "all"),
                                  limits=_limits(opts, res.nominal_gains), joint_names=joints):
            ns = round(p.seconds * NS)
            out[schemas.REPORT_CONVERGENCE].append((ns, schemas.convergence(
                ns, p.seconds, p.unloaded_seconds, p.loaded_seconds, joints, p.gains, p.rel_std)))
    val, crossed = validation_for_plot(res)
    meta = {
        "bags": ", ".join(res.bags),
        "method": res.method,
        "time_axis": "log time = seconds from the start of a record (convergence: of every record)",
        "records": "; ".join(
            f"{o.source} ({o.condition}) {record_seconds(o):.3f} s" for o in res.observations
        ),
    }
    if val is not None:
        meta["forces_record"] = (
            f"{val.source} ({'cross-validation' if crossed else 'identification record'})"
        )
        ticks = int(1 if res.diagnostics is None else res.diagnostics.decimation)
        for k, t in enumerate(np.asarray(val.t, float)):
            ns = round(t * NS)
            out[schemas.REPORT_FORCES].append((ns, schemas.forces(
                ns, joints, val.tau_measured[:, k], val.tau_model[:, k], ticks)))
        end = max(end, float(val.t[-1]) if len(val.t) else 0.0)
    ns = round(end * NS)
    out[schemas.IDENTIFIED].append((ns, schemas.identified(ns, res.message_fields())))
    return out, meta


def write_report_mcap(res: IdentificationResult, path: str | Path) -> Path:
    """Write the MCAP file at ``path`` (replaced if it exists); ConfigError when it cannot be."""
    import foxglove

    path = Path(path)
    messages, meta = report_messages(res)
    ctx = foxglove.Context()  # its own: only these channels go to the file
    try:
        writer = foxglove.open_mcap(path, allow_overwrite=True, context=ctx)
    except (RuntimeError, OSError) as exc:
        raise ConfigError(
            f"cannot write {path}: {str(exc).removeprefix('FoxgloveError: ')}"
        ) from None
    with writer:
        channels = {
            c: foxglove.Channel("/" + c, schema=schemas.SCHEMAS[c], context=ctx) for c in CHANNELS
        }
        ordered = sorted(
            ((ns, c, msg) for c, items in messages.items() for ns, msg in items), key=lambda x: x[0]
        )
        for ns, topic, msg in ordered:  # log times non-decreasing through the file
            channels[topic].log(msg, log_time=ns)
        writer.write_metadata("orthoglide_report", meta)
    return path
