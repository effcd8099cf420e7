"""The current loop's lag with the leave-one-period-out instrument (identify/current_lag.py,
``lag_model: auto``)."""
import numpy as np
import pytest
from simulated import simulated_pair

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.identify import IdentifyOptions, Record, identify_records
from orthoglide_ident.identify.columns.current_lag import (
    MAX_SEARCH_S,
    MIN_PERIODS,
    LiveLagInstrument,
    find_period,
    lag_instrument,
)
from orthoglide_ident.model.registry import load_robot

ORTHOGLIDE = load_robot("orthoglide")  # the robot these records are of

T = 1e-3  # s, the driver's tick
G_TRUE = np.array([2170.0, 2100.0, 2070.0])  # config/plant.yaml
LAG_S = 1.2e-4  # config/plant.yaml, realistic profile's current_lag


def _fourier(n: int, period_s: float) -> np.ndarray:
    t = np.arange(n) * T
    w = 2 * np.pi / period_s
    return np.stack([0.03 * np.sin(w * t + j) + 0.01 * np.cos(3 * w * t - j) for j in range(3)], 1)


def test_period_found_when_the_trajectory_repeats_and_only_then():
    q = _fourier(30000, 1.5)
    assert find_period(q, T) == 1500
    q[:1500] += 0.004 * np.sin(np.linspace(0, np.pi, 1500))[:, None]  # a start transient
    assert find_period(q, T) == 1500
    assert find_period(q[:1500 * MIN_PERIODS - 1], T) is None  # too few periods
    walk = np.cumsum(np.random.default_rng(0).standard_normal((30000, 3)), axis=0) * 1e-4
    assert find_period(walk, T) is None
    noisy = q + 1e-3 * np.random.default_rng(1).standard_normal(q.shape)  # 3 % of q's rms
    assert find_period(noisy, T) is None


def test_instrument_holds_no_noise_of_its_own_period():
    """The value at a tick is the mean of v̇ over the other steady periods at its phase: a
    disturbance in period 3 leaves period 3's instrument alone and moves the others' by
    1/(n - 2) of it; the first period (a transient) enters no mean."""
    n_per, P = 12, 1500
    q = _fourier(n_per * P, 1.5)
    v = np.tile(np.sin(np.linspace(0, 2 * np.pi, P, endpoint=False)), (n_per, 1)).reshape(-1)
    v = np.stack([v, 2 * v, 3 * v], 1)
    z0 = lag_instrument(q, v, T)
    v_dot = np.gradient(v, T, axis=0)  # one-sided at the record's last tick: 3e-5 of it
    np.testing.assert_allclose(z0[2 * P:3 * P], v_dot[2 * P:3 * P], atol=1e-4 * np.abs(v_dot).max())
    bump = np.zeros_like(v)
    bump[3 * P + 700:3 * P + 710] = 0.1
    z = lag_instrument(q, v + bump, T)
    d = np.gradient(bump, T, axis=0)
    np.testing.assert_allclose(z[3 * P:4 * P], z0[3 * P:4 * P], atol=1e-9)
    np.testing.assert_allclose(z[5 * P:6 * P] - z0[5 * P:6 * P], d[3 * P:4 * P] / (n_per - 2),
                               atol=1e-9)
    first = np.zeros_like(v)
    first[700:710] = 5.0
    np.testing.assert_allclose(lag_instrument(q, v + first, T)[P:], z0[P:], atol=1e-9)


@pytest.fixture(scope="module")
def realistic_pair():
    """20 s unloaded + 20 s loaded on the simulated realistic drive (0.12 ms current-loop lag,
    2 mA, Stribeck, screw ripple at the 10 mm lead)."""
    return simulated_pair(20.0, (11, 12), "real", profile="realistic")


def test_lag_of_the_realistic_drive_identified_despite_the_current_noise(realistic_pair, tmp_path):
    """τ of every joint near the plant's 0.12 ms, its σ an honest bar; the raw derivative of
    v_τ as the column finds 0.22-0.31 ms here (the noise bias, drive_terms.py). The gains keep
    their σ (the lag costs three unknowns)."""
    opts = IdentifyOptions.of(screw_lead_m=0.01)  # lag_model: auto, the default
    res = identify_records(realistic_pair, options=opts, essential=True, model=ORTHOGLIDE)
    tau = np.array([x.tau_ms for x in res.current_lag]) * 1e-3
    sig = np.array([x.tau_std_ms for x in res.current_lag]) * 1e-3
    assert [x.joint for x in res.current_lag] == ["q11", "q12", "q13"]
    assert np.all(np.abs(tau - LAG_S) < 3 * sig) and np.all(sig < 0.5 * LAG_S), (tau, sig)
    assert abs(tau.mean() - LAG_S) < 3 * np.sqrt(np.sum(sig ** 2)) / 3
    assert [x.joint for x in res.essential.current_lag] == ["q11", "q12", "q13"]
    assert "current-loop lag modelled: q11" in res.to_text()
    # the report's force plot multiplies the rows' lag columns too
    from orthoglide_ident.report import write_report

    assert "torques.png" in [p.name for p in write_report(res, tmp_path)]
    g = np.array([x.value for x in res.drive_gains])
    s = np.array([x.rel_std for x in res.drive_gains])
    off = identify_records(
        realistic_pair,
        options=IdentifyOptions.of(screw_lead_m=0.01, lag_model="off"),
        model=ORTHOGLIDE,
    )
    assert off.current_lag == []
    s_off = np.array([x.rel_std for x in off.drive_gains])
    assert np.all(s < 1.25 * s_off)
    assert np.all(np.abs(g / G_TRUE - 1) < 3 * s)
    # cross-validation multiplies the lag columns too (the records predict themselves)
    val = identify_records(realistic_pair[:1], options=opts, method="wls", gains=list(g),
                           validation=realistic_pair[1:], model=ORTHOGLIDE)
    assert val.current_lag and max(j.noise_ratio for j in val.validation[0].joints) < 1.5


def test_records_that_do_not_repeat_keep_the_papers_model(realistic_pair):
    """A record cut to fewer than MIN_PERIODS periods does not repeat: with it, the lag is not
    modelled at all (rows with a zero lag column would still hold the lag's force: a third of
    such rows halved τ) and the result is the one of lag_model: off — whether the other record
    repeats or not."""
    def cut(r):
        return Record.from_arrays(r.source, r.stamps_q_ns[:5000], r.q[:5000], r.v_tau[:5000],
                                  r.condition, r.payload_mass, joint_names=ORTHOGLIDE.joint_names)

    for recs in ([cut(r) for r in realistic_pair], [cut(realistic_pair[0]), realistic_pair[1]]):
        on = identify_records(recs, options=IdentifyOptions.of(check_excitation=False),
                              model=ORTHOGLIDE)
        off = identify_records(
            recs, options=IdentifyOptions.of(lag_model="off", check_excitation=False),
            model=ORTHOGLIDE
        )
        assert on.current_lag == []
        assert on.record_reports[0].n_not_repeating == 1
        assert [p.name for p in on.parameters] == [p.name for p in off.parameters]
        np.testing.assert_allclose([g.value for g in on.drive_gains],
                                   [g.value for g in off.drive_gains], rtol=1e-12)


def test_lag_model_is_a_word():
    assert IdentifyOptions.from_mapping({"lag_model": False}).solve.lag_model == "off"  # YAML's off
    with pytest.raises(ConfigError, match="lag_model must be 'auto' or 'off'"):
        IdentifyOptions.from_mapping({"lag_model": "periodic"})


def _live_instrument(q: np.ndarray, v: np.ndarray, sizes: tuple[int, ...]):
    """The ticks through a LiveLagInstrument in batches of ``sizes`` (cycled): what came out
    after each push (None while held), then the instrument."""
    live, a, i, out = LiveLagInstrument(T, q.shape[1]), 0, 0, []
    stamps = np.arange(q.shape[0])
    while a < q.shape[0]:
        b = a + sizes[i % len(sizes)]
        out.append(live.push(stamps[a:b], q[a:b], v[a:b]))
        a, i = b, i + 1
    out.append(live.finish())
    return live, out


def test_live_instrument_holds_the_first_periods_then_uses_the_past_ones():
    """Live, ticks are held until the period is found on the first 1, 2, 3... s (4 periods:
    6 s here); those of the first F = 3 whole periods then get the offline instrument over those
    periods (the mean over the other steady ones), every later tick the mean over the steady
    periods before its own. Every tick comes out once, in order, whatever the batches."""
    P, n_per = 1500, 12
    q = _fourier(n_per * P, 1.5)
    v = np.random.default_rng(2).standard_normal((n_per * P, 3))
    v_dot = np.gradient(v, T, axis=0)
    z = []
    for sizes in ((n_per * P,), (1, 7, 100, 999, 333)):
        live, out = _live_instrument(q, v, sizes)
        ticks = [x for x in out if x is not None]
        assert np.array_equal(np.concatenate([x[0] for x in ticks]), np.arange(n_per * P))
        np.testing.assert_array_equal(np.concatenate([x[2][:, :3] for x in ticks]), v)
        z.append(np.concatenate([x[2][:, 3:] for x in ticks]))
    np.testing.assert_array_equal(z[0], z[1])
    assert live.P == P and live.repeats
    first = next(i for i, x in enumerate(out) if x is not None)
    assert 6000 <= sum(sizes[k % 5] for k in range(first + 1)) < 6000 + 999  # held until 6 s
    z = z[0]
    F = (6000 - 1) // P  # whole periods with the tick after them at the 6th second
    for k in (0, 700, P + 3, 2 * P + 1499):  # mean over the other steady periods of the F
        others = [j for j in range(1, F) if j != k // P]
        np.testing.assert_allclose(z[k], np.mean([v_dot[j * P + k % P] for j in others], 0),
                                   rtol=1e-12, atol=1e-9)
    for k in (F * P, F * P + 700, 9 * P + 1499, n_per * P - 2):
        p = k // P
        np.testing.assert_allclose(z[k], np.mean([v_dot[j * P + k % P] for j in range(1, p)], 0),
                                   rtol=1e-12, atol=1e-9)


def test_live_instrument_gives_up_on_a_trajectory_that_does_not_repeat():
    """No period within MAX_SEARCH_S (or before the segment ends): the held ticks come out with a
    zero instrument, and so do the later ones."""
    walk = np.cumsum(np.random.default_rng(0).standard_normal((40000, 3)), axis=0) * 1e-4
    v = np.ones_like(walk)
    live, out = _live_instrument(walk, v, (700,))
    first = next(i for i, x in enumerate(out) if x is not None)
    assert (first + 1) * 700 >= MAX_SEARCH_S / T and live.repeats is False
    ticks = np.concatenate([x[2] for x in out if x is not None])
    assert ticks.shape == (40000, 6) and not ticks[:, 3:].any()
    short, out = _live_instrument(_fourier(5000, 1.5), np.ones((5000, 3)), (1000,))
    assert out[:-1] == [None] * 5 and out[-1][0].shape == (5000,) and short.repeats is False
    assert not out[-1][2][:, 3:].any()


def test_live_instrument_notices_a_trajectory_that_stops_repeating():
    """A trajectory switched mid-segment (1.5 s period for 9 s, then 1.2 s): live, the period's
    end after the switch breaks find_period's repeat criterion, ``repeats`` turns False with the
    reason, and the instrument is zero from there (the identification then leaves the lag out,
    as offline, where the whole segment has no period)."""
    n1, n = 9000, 15000
    q = np.concatenate([_fourier(n1, 1.5), _fourier(n - n1, 1.2)])
    v = np.random.default_rng(3).standard_normal((n, 3))
    live, out = _live_instrument(q, v, (250,))
    assert live.P == 1500 and live.repeats is False and "stopped repeating" in live.why
    z = np.concatenate([x[2][:, 3:] for x in out if x is not None])
    first_zero = int(np.flatnonzero(~z.any(axis=1))[0])
    assert n1 <= first_zero <= n1 + 1500 + 250 and not z[first_zero:].any()
    assert find_period(q, T) is None
    steady, out = _live_instrument(_fourier(n, 1.5), v, (250,))
    assert steady.repeats and all(x is None or x[2][:, 3:].any() for x in out[-10:-1])
