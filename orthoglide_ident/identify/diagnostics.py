"""What an identification reports beside its numbers: per-record reports, warnings, diagnostics.

Shared by the offline path (pipeline.py) and the live one (live.py, live_recording.py): both
finish a solved identification into the same JSON ``diagnostics``.
"""
from __future__ import annotations

from collections.abc import Sequence

from orthoglide_ident.identify.options import IdentifyOptions
from orthoglide_ident.identify.records.segments import SegmentReport
from orthoglide_ident.identify.solve.answer import Solved
from orthoglide_ident.results import Diagnostics, IdentificationResult, RecordReport

__all__ = ["bag_report", "finish_result"]


def bag_report(rep: SegmentReport, source: str, condition: str | None, payload_mass: float,
               equations: Sequence[int], sources: str = "") -> RecordReport:
    """One record's entry of ``diagnostics.bags``: pairing, gaps, reversals, equations, and
    which topics and fields carried q and the current; the figures as they are now (a live
    recording's go on counting)."""
    figures = dict(vars(rep), reordered=tuple(rep.reordered))
    return RecordReport(**figures, bag=source, condition=condition, payload_mass=payload_mass,
                        equations_per_joint=tuple(equations), sources=sources)


def finish_result(result: IdentificationResult, solved: Solved, reports: Sequence[RecordReport],
                  warnings: list[str], opts: IdentifyOptions, timings: dict[str, float]) -> None:
    """Warnings and diagnostics of a solved identification (the JSON's ``diagnostics``)."""
    if result.condition_number > opts.solve.warn_condition:
        warnings.append(f"condition number of the scaled observation matrix is "
                        f"{result.condition_number:.3g}: some base parameters are poorly excited "
                        "(see their %σ; --essential keeps the well-identified ones)")
    result.warnings = list(warnings) + [w for w in result.warnings if w not in warnings]
    result.diagnostics = Diagnostics(
        samples_used=int(sum(r.n_used for r in reports)),
        samples_dropped=int(sum(r.n_paired - r.n_used + r.n_unpaired_joint_states
                                + r.n_unpaired_current_reference for r in reports)),
        segments=int(sum(r.n_segments for r in reports)),
        rows=int(sum(sum(r.equations_per_joint) for r in reports)),
        solver=solved.solver,
        decimation=opts.observe.decimation,
        bags=tuple(reports),
        timings_s={k: round(v, 4) for k, v in timings.items()},
        options=dict(opts.flat()),
    )
