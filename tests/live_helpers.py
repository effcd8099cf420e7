"""What the live identification's tests share: feeding a Record to it as the topics would, comparing
two results, a simulated arm run as a bag's Record."""
from __future__ import annotations

import numpy as np

from orthoglide_ident.identify import IdentifyOptions, LiveIdentification, Record
from orthoglide_ident.model.robot import Payload
from orthoglide_sim.arms.record import ArmRecord


def feed(live: LiveIdentification, rec: Record, batches=(100,), offset: int = 0, seed: int = 0,
         names_q=None) -> list[str]:
    """One recording, both topics in batches drawn from ``batches``; current_reference trails
    joint_states by ``offset`` ticks. Returns the warnings of the add_* and stop calls."""
    rng = np.random.default_rng(seed)
    live.start_recording(rec.source, rec.condition, rec.payload_mass)
    nq, nv = len(rec.stamps_q_ns), len(rec.stamps_v_ns)
    a = b = 0
    out: list[str] = []
    while a < nq or b < nv:
        if a < nq:
            k = int(rng.choice(batches))
            out += live.add_joint_states(rec.stamps_q_ns[a:a + k], names_q or rec.names_q,
                                         rec.q[a:a + k])
            a += k
        while b < nv and (b < a - offset or a >= nq):
            k = int(rng.choice(batches))
            out += live.add_current_reference(rec.stamps_v_ns[b:b + k], rec.names_v,
                                              rec.v_tau[b:b + k])
            b += k
    return out + live.stop_recording()


def rel_sigma_diff(a, b) -> tuple[float, float]:
    """Max relative difference of the honest and of the eqs. (38)-(39) σ of two results."""
    ea = a.drive_gains + a.parameters
    eb = b.drive_gains + b.parameters
    h = np.array([y.rel_std / x.rel_std - 1 for x, y in zip(ea, eb)])
    p = np.array([y.rel_std_paper / x.rel_std_paper - 1 for x, y in zip(ea, eb)])
    return float(np.abs(h).max()), float(np.abs(p).max())


def rel_diff(a, b) -> tuple[float, float]:
    """Max relative difference of the gains and of the base parameters of two results."""
    ga = np.array([g.value for g in a.drive_gains])
    gb = np.array([g.value for g in b.drive_gains])
    pa = np.array([p.value for p in a.parameters])
    pb = np.array([p.value for p in b.parameters])
    return float(np.abs(gb / ga - 1).max()), float(np.abs(pb / pa - 1).max())


def as_record(rec: ArmRecord, name: str) -> Record:
    """What a bag of the run holds, in memory: the payload's shape as its tag gives it."""
    payload = None
    if rec.payload is not None:
        I = rec.payload.body.inertia
        payload = Payload(rec.payload.mass, rec.payload.frame, tuple(rec.payload.body.com),
                          (I[0, 0], I[0, 1], I[0, 2], I[1, 1], I[1, 2], I[2, 2]))
    cond = "loaded" if payload else "unloaded"
    return Record.from_arrays(name, rec.stamps_ns, rec.q, rec.v_tau, cond, rec.payload_mass,
                              rec.joint_names, payload)


def live_result(model, records, options: IdentifyOptions, batch: int = 500):
    """The live identification fed ``records`` in batches of ``batch`` ticks, each recording with
    its payload's shape as the recorder's status carries it."""
    from orthoglide_ident.identify import LiveIdentification

    live = LiveIdentification(options, model=model)
    for rec in records:
        live.start_recording(rec.source, rec.condition, rec.payload_mass, rec.payload)
        for a in range(0, len(rec.stamps_q_ns), batch):
            live.add_joint_states(rec.stamps_q_ns[a:a + batch], rec.names_q, rec.q[a:a + batch])
            live.add_current_reference(
                rec.stamps_v_ns[a : a + batch], rec.names_v, rec.v_tau[a : a + batch]
            )
        live.stop_recording()
    return live.result()
