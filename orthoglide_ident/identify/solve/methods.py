"""The identification methods, registered once (as rosbags registers its storage plugins).

Each method is a row of :data:`METHODS`: its name (``--method``, the service's ``method``, the
result's ``method``), what it identifies, whether it takes the drive gains or identifies them,
the result fields it fills, the topic the identification node latches its answer on, and the
function that solves it. The refinements every method can add (the essential parameters, the
physically consistent set) are rows of :data:`REFINEMENTS`, with the option that asks for them
and the result field that holds them. The CLI, the node, the offline and the live paths read
these tables; a new method (instrumental variables, say) is its own module plus one row here.

    method = get("tls")                     # IdentificationError for an unknown name
    solved = solve(factors, robot, opts, "wls", gains=[2001.2] * 3, layout=layout)
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from orthoglide_ident.errors import IdentificationError
from orthoglide_ident.identify.columns.layout import ColumnLayout, plain_layout
from orthoglide_ident.identify.options import IdentifyOptions
from orthoglide_ident.identify.solve.answer import (
    Solved,
    check_length,
    check_rows,
    friction_sign_warnings,
    solve_tls,
    solve_wls,
)
from orthoglide_ident.identify.solve.factors import RecordFactors
from orthoglide_ident.identify.solve.iv_answer import cross_check, solve_iv
from orthoglide_ident.identify.solve.payload_report import split_payload

__all__ = ["CROSS_CHECKS", "DEFAULT_METHOD", "METHODS", "REFINEMENTS", "Method", "Refinement",
           "get", "solve"]


@dataclass(frozen=True)
class Method:
    """One identification method: see the module docstring."""

    name: str
    help: str  # one line for --help and the node's parameter
    title: str  # the first line of the result's text report
    gains_given: bool  # True: the drive gains are an input (--gains), the payload mass estimated
    result_fields: tuple[str, ...]  # what IdentificationResult fields it fills beyond the common
    topic: str  # where the identification node latches its answer (orthoglide_msgs)
    # (factors, robot, layout, opts, gains, essential, bags) -> Solved
    solve: Callable[..., Solved]
    cross_checked: bool = False  # its complete answer is cross-checked (options.cross_check)
    cross_checks: bool = False  # it can cross-check another method's answer (--cross-check NAME)
    gains_converge: bool = False  # the report shows its gains converging as the records grow
    reports_progress: bool = False  # its solve takes a ``progress`` (TLS: the subset search)


@dataclass(frozen=True)
class Refinement:
    """A step any method can add to its answer: the option that asks for it, the result field."""

    name: str
    help: str
    option: str  # IdentifyOptions field or flag that asks for it
    result_field: str  # IdentificationResult field that holds it
    topic: str = ""  # where the identification node latches it, if on a topic of its own


def _tls(factors, model, layout, opts, gains, essential, bags, progress=None) -> Solved:
    return solve_tls(factors, model, layout, opts, essential, bags, progress)


def _iv(factors, model, layout, opts, gains, essential, bags) -> Solved:
    return solve_iv(factors, model, layout, opts, gains, essential, bags)


METHODS: dict[str, Method] = {m.name: m for m in (
    Method("tls", "IDIM-TLS (eqs. 33-39): drive gains and base parameters at once, scaled by the "
                  "known payload mass",
           "IDIM-TLS (drive gains and base parameters, scale from the payload mass)", False,
           ("drive_gains", "payload_mass"), "orthoglide/identified_parameters", _tls,
           cross_checked=True, gains_converge=True, reports_progress=True),
    Method("wls", "IDIM-WLS (eqs. 24-28): drive gains given (default the robot's nominal ones), "
                  "payload mass of the loaded records estimated",
           "IDIM-WLS with given drive gains (payload mass estimated)", True,
           ("payloads",), "orthoglide/identified_parameters/wls", solve_wls),
    Method("iv", "IDIM-IV (Janot et al. 2014): drive gains and base parameters by instrumental "
                 "variables (the identified model's currents), scaled by the known payload mass; "
                 "unbiased when the joints' current noise differs",
           "IDIM-IV (instruments: the identified model's currents; scale from the payload mass)",
           False,
           ("drive_gains", "payload_mass"), "orthoglide/identified_parameters/iv", _iv,
           cross_checks=True),
)}
# the values of options.cross_check other than "none": the methods that can cross-check
CROSS_CHECKS: tuple[str, ...] = tuple(m.name for m in METHODS.values() if m.cross_checks)
DEFAULT_METHOD = "tls"

REFINEMENTS: dict[str, Refinement] = {r.name: r for r in (
    Refinement("essential", "essential parameters (Sect. 5.2): the base parameters whose %σ the "
                            "data bound, the others cancelled", "essential", "essential"),
    Refinement("consistent", "physically consistent standard parameters (pseudo-inertias ⪰ 0, "
                             "ia, fv, fs ≥ 0) behind the answer", "consistent", "consistency",
               "orthoglide/identified_parameters/consistent"),
)}


def get(name: str) -> Method:
    """The method called ``name``; IdentificationError naming the known ones otherwise."""
    try:
        return METHODS[name]
    except KeyError:
        raise IdentificationError(f"unknown method {name!r}: use "
                                  f"{' or '.join(METHODS)}") from None


def _named(result, m: Method) -> None:
    """The result (and its essential answer) named by the table's row: the method's name and the
    title its text report opens with (results.py sits below this table: it reads them as data)."""
    for r in (result, result.essential):
        if r is not None:
            r.method, r.title = m.name, m.title


def solve(factors: list[RecordFactors], model, opts: IdentifyOptions,
          method: str = DEFAULT_METHOD, gains: Sequence[float] | None = None,
          essential: bool = False, bags: Sequence[str] = (),
          progress: Callable[..., None] | None = None, *,
          layout: ColumnLayout | None = None) -> Solved:
    """The method on the factors, the payload's identified parameters split from the robot's
    (a payload known by its mass, Sect. 4.3), then the consistent set when ``opts.consistent``;
    raises the product's errors with a reason. ``model``: the robot; ``layout``: the columns of
    the factors (columns/layout.py; default the robot's own, nothing beside W).
    ``progress(stage, done, total, unit)`` (None: silent) hears the stages: the solve, the
    partial answer's subset search (TLS), the cross-check, the consistency fits."""
    if layout is None:
        layout = plain_layout(model)
    m = get(method)
    if not factors:
        raise IdentificationError("no bag given")
    if m.gains_given or not (opts.solve.partial_answers and opts.solve.check_excitation):
        check_rows(factors, model, opts)
    else:  # TLS: a joint that hardly moved is a partial answer, a short record is refused
        check_length(factors, opts)
    if opts.consistency.consistent and layout.has_payload_unknowns:
        raise IdentificationError(
            "--consistent needs the payload's CoM and inertia: with only its mass known they are "
            "identified (Sect. 4.3); tag them or give --payload-known point")
    tell = progress or (lambda *a: None)
    tell(f"solving (IDIM-{m.name.upper()})", 0, 0, "")  # a stage with nothing to count
    # a method that reports its own steps (TLS: the subset search) takes the progress too
    out = m.solve(factors, model, layout, opts, gains, essential, list(bags),
                  **({"progress": progress} if progress is not None and m.reports_progress
                     else {}))
    _named(out.result, m)
    if m.cross_checked and opts.solve.cross_check in CROSS_CHECKS and out.result.complete:
        # after TLS, IDIM-IV's gains beside (issue 43); marked only when the checks are on
        tell(f"cross-checking by IDIM-{opts.solve.cross_check.upper()}", 0, 0, "")
        cross_check(out, factors, model, opts.solve.check_excitation)
    split_payload(out.result, layout)
    out.result.warnings.extend(friction_sign_warnings(out.result))
    if opts.consistency.consistent and not out.result.complete:
        out.result.warnings.append("--consistent is not run on a partial answer: the standard "
                                   "parameters need every gain")
    elif opts.consistency.consistent:  # physically consistent standard parameters behind the answer
        from orthoglide_ident.identify.consistency.fit import attach

        attach(out, model, opts, progress)
    return out
