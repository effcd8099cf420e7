"""Identification results: one dataclass, serialised once to the JSON of DESIGN §4 and to a table.

Relative standard deviations (``rel_std``) are fractions (0.002 = 0.2 %σ); the table prints %σ.
Units: drive gains N/A, payload mass kg, residuals N, base parameters in the SI units of the
standard parameters they regroup (kg, kg·m, kg·m², N·s/m, N).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any


def _num(x: float) -> float | None:
    """JSON-safe float (inf/NaN become null)."""
    x = float(x)
    return x if math.isfinite(x) else None


@dataclass
class Estimate:
    """One identified quantity: value, relative std (fraction), the expression it stands for."""

    name: str
    value: float
    rel_std: float
    expression: str = ""

    def to_json(self) -> dict[str, Any]:
        return {"name": self.name, "value": _num(self.value), "rel_std": _num(self.rel_std),
                "expression": self.expression}


@dataclass
class PayloadMass:
    """Payload mass m_7: known (weighed, TLS scale) or estimated (WLS)."""

    value: float
    rel_std: float
    known: bool
    tagged: float | None = None  # the mass written in the bag tag, kg
    bags: list[str] = field(default_factory=list)

    def to_json(self) -> dict[str, Any]:
        return {"value": _num(self.value), "rel_std": _num(self.rel_std), "known": self.known,
                "tagged": None if self.tagged is None else _num(self.tagged), "bags": self.bags}


@dataclass
class IdentificationResult:
    """What ``identify`` found; ``to_json()`` is the document of DESIGN §4."""

    method: str  # "tls" | "wls"
    joint_names: list[str]
    drive_gains: list[Estimate]  # name = joint name
    drive_gains_given: bool  # True for WLS (gains were an input, rel_std 0)
    parameters: list[Estimate]
    payload_mass: PayloadMass | None
    payloads: list[PayloadMass]
    condition_number: float
    residual_rms: list[float]  # per joint, N
    bags: list[str]
    diagnostics: dict[str, Any] = field(default_factory=dict)
    essential: "IdentificationResult | None" = None
    removed: list[str] = field(default_factory=list)  # cancelled base parameters (essential)
    validation: list[dict[str, Any]] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    # In-memory extras for plots (report.py); not serialised.
    validation_details: list[Any] = field(default_factory=list, repr=False, compare=False)
    observations: list[Any] = field(default_factory=list, repr=False, compare=False)

    @property
    def residual_rms_total(self) -> float:
        return math.sqrt(sum(r * r for r in self.residual_rms) / max(len(self.residual_rms), 1))

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "method": self.method,
            "joint_names": list(self.joint_names),
            "drive_gains": [{"joint": g.name, "value": _num(g.value), "rel_std": _num(g.rel_std)}
                            for g in self.drive_gains],
            "drive_gains_given": self.drive_gains_given,
            "parameters": [p.to_json() for p in self.parameters],
            "payload_mass": None if self.payload_mass is None else self.payload_mass.to_json(),
            "payloads": [p.to_json() for p in self.payloads],
            "condition_number": _num(self.condition_number),
            "residual_rms": _num(self.residual_rms_total),
            "residual_rms_per_joint": [_num(r) for r in self.residual_rms],
            "bags": list(self.bags),
            "units": {"drive_gains": "N/A", "payload_mass": "kg", "residual_rms": "N",
                      "rel_std": "fraction (0.01 = 1 %)"},
            "warnings": list(self.warnings),
        }
        if self.removed:
            out["removed"] = list(self.removed)
        if self.essential is not None:
            out["essential"] = self.essential.to_json()
        if self.validation:
            out["validation"] = self.validation
        if self.diagnostics:
            out["diagnostics"] = self.diagnostics
        return out

    def write_json(self, path: str | Path) -> None:
        Path(path).write_text(json.dumps(self.to_json(), indent=2) + "\n")

    def message_fields(self) -> dict[str, Any]:
        """The fields of orthoglide_msgs/IdentifiedParameters (header and stamp excluded)."""
        return {
            "method": self.method,
            "joint_names": list(self.joint_names),
            "drive_gains": [float(g.value) for g in self.drive_gains],
            "drive_gains_rel_std": [float(g.rel_std) for g in self.drive_gains],
            "names": [p.name for p in self.parameters],
            "values": [float(p.value) for p in self.parameters],
            "rel_std": [float(p.rel_std) if math.isfinite(p.rel_std) else -1.0
                        for p in self.parameters],
            "payload_mass": float(self.payload_mass.value) if self.payload_mass else 0.0,
            "residual_rms": float(self.residual_rms_total),
            "condition_number": float(self.condition_number)
            if math.isfinite(self.condition_number) else -1.0,
            "source_bags": list(self.bags),
        }

    # ------------------------------------------------------------------ text
    def to_text(self) -> str:
        """A readable table; with essential parameters, base and essential side by side."""
        ess = self.essential
        lines: list[str] = []
        head = {"tls": "IDIM-TLS (drive gains and base parameters, scale from the payload mass)",
                "wls": "IDIM-WLS with given drive gains (payload mass estimated)"}
        lines.append(head.get(self.method, self.method))
        variant = self.diagnostics.get("solver", {}).get("tls_noisy_columns")
        if self.method == "tls" and variant:
            lines.append({"currents": "mixed LS-TLS: W exact, errors in the current references",
                          "all": "TLS of eqs. (35)-(36): errors in every column of W_tot"}
                         .get(variant, variant))
        lines.append(f"bags: {', '.join(self.bags)}")
        lines.append("")

        def pct(x: float) -> str:
            return "    -" if not math.isfinite(x) else (f"{100 * x:7.3g}" if x < 10 else ">1000%")

        w = max([len(p.name) for p in self.parameters] + [12])
        if ess is None:
            hdr = f"  {'parameter':<{w}} {'value':>12} {'%σ':>7}"
        else:
            hdr = (f"  {'parameter':<{w}} {'base':>12} {'%σ':>7}   {'essential':>12} {'%σ':>7}")
        gtitle = "drive gains (N/A)" + (" — given" if self.drive_gains_given else "")
        lines.append(gtitle)
        lines.append(hdr)
        eg = {g.name: g for g in ess.drive_gains} if ess else {}
        for g in self.drive_gains:
            row = f"  g_tau {g.name:<{w - 6}} {g.value:12.6g} {pct(g.rel_std)}"
            if ess is not None:
                e = eg[g.name]
                row += f"   {e.value:12.6g} {pct(e.rel_std)}"
            lines.append(row)
        lines.append("")
        lines.append("base parameters" + (" (— = cancelled as non-essential)" if ess else ""))
        lines.append(hdr + "   expression")
        ep = {p.name: p for p in ess.parameters} if ess else {}
        for p in self.parameters:
            row = f"  {p.name:<{w}} {p.value:12.6g} {pct(p.rel_std)}"
            if ess is not None:
                e = ep.get(p.name)
                row += (f"   {e.value:12.6g} {pct(e.rel_std)}" if e else f"   {'—':>12} {'':>7}")
            lines.append(row + (f"   {p.expression}" if p.expression else ""))
        lines.append("")
        for pm in self.payloads:
            what = "known (weighed)" if pm.known else "estimated"
            tag = "" if pm.tagged is None or pm.known else f", tagged {pm.tagged:.4g} kg"
            lines.append(f"payload mass m_7: {pm.value:.5g} kg ± {pct(pm.rel_std).strip()} % "
                         f"({what}{tag})")
        lines.append(f"condition number (scaled W): {self.condition_number:.4g}")
        lines.append("residual rms (N): " + ", ".join(
            f"{j} {r:.4g}" for j, r in zip(self.joint_names, self.residual_rms)))
        if ess is not None:
            lines.append(f"essential parameters: {len(ess.parameters)} kept of "
                         f"{len(self.parameters)} ({ess.diagnostics.get('stopped_because', '')}); "
                         "residual rms (N): " + ", ".join(
                             f"{j} {r:.4g}" for j, r in zip(ess.joint_names, ess.residual_rms)))
        for v in self.validation:
            lines.append(f"cross-validation on {v['bag']}: " + ", ".join(
                f"{j['joint']} {j['residual_rms']:.3g} N rms ({100 * j['relative_error']:.1f} %)"
                for j in v["joints"]))
        d = self.diagnostics
        if d.get("samples_used") is not None:
            lines.append(f"samples: {d['samples_used']} used, "
                         f"{d.get('samples_dropped', 0)} dropped,"
                         f" {d.get('segments', 0)} segments, {d.get('rows', 0)} equations after "
                         f"decimation by {d.get('decimation', '')}")
        for wmsg in self.warnings:
            lines.append(f"warning: {wmsg}")
        return "\n".join(lines)
