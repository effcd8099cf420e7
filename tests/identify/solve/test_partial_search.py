"""Partial answers when the full set of gains is not separated (issue 43): the subsets of the
free gains searched (partial.search_subsets), the largest separated one with honest σ answered,
each gain left out with what goes wrong with it; nothing separated -> the real reason.

The record shape: the UR10 (32.7 kg) with a 2.8 kg payload of unknown CoM, logged at 90.9 Hz on
a 10/12 ms clock, positions printed to 1e-4 rad (orthoglide_sim/arms/big_arm.py; 20 s records
at a 1 ms plant step to keep the test short). The truth is the MuJoCo plant's."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from orthoglide_ident.errors import ExcitationError
from orthoglide_ident.identify import IdentifyOptions, identify_records
from orthoglide_ident.identify.solve import partial
from orthoglide_ident.model.registry import load_robot
from orthoglide_sim.arms.big_arm import UR10_FILE, big_arm_truth, pair_records, simulate_pair

SECONDS = 20.0
STEP = 1e-3  # s, the plant's (divides the 10/12 ms ticks)
NAMES = ("a", "b", "c", "d", "e", "f", "g", "h")


# --- the search on made-up trials (no solve) ----------------------------------------------
def made_up(ratio_of, bias=None):
    """A trial function: each subset's ratio from ``ratio_of`` (a failure above 0.5); gains 1
    with σ 0.01, plus ``bias(kept, j)`` on gain j."""
    def trial(kept):
        r = ratio_of(kept)
        gains = {j: 1.0 + (bias(kept, j) if bias else 0.0) for j in kept}
        return partial.Trial(kept, r, None if r <= 0.5 else f"not separated ({r:.2f})", gains,
                             {j: 0.01 for j in kept})
    return trial


def test_the_largest_separated_subset_with_the_least_ratio():
    # gain 0 spoils every subset it is in; among the 4-subsets of 1..4, the least ratio wins
    def ratio(kept):
        return 0.9 if 0 in kept else 0.1 + 0.01 * sum(kept)

    best, tried = partial.search_subsets(range(5), made_up(ratio), NAMES)
    assert best.kept == frozenset({1, 2, 3, 4}) and best.failure is None
    assert len(tried) == 5 + 4  # the five 4-subsets; the answer's own 3-subsets (nested check)
    reasons = partial.search_reasons(best, range(5), made_up(ratio), tried, NAMES)
    assert list(reasons) == [0]
    assert reasons[0].startswith("a not fixed beside the determined gains: with it, not "
                                 "separated (0.90) (without it s_c/s_c-1 = 0.20)")


def test_a_subset_whose_gains_move_when_one_leaves_is_not_honest():
    # {1, 2} is separated but gain 2 moves by 10 σ when 1 leaves: 1's rows bias it
    def ratio(kept):
        return 0.9 if 0 in kept else 0.2

    def bias(kept, j):
        return 0.1 if (j == 2 and 1 in kept) else 0.0

    best, tried = partial.search_subsets(range(3), made_up(ratio, bias), NAMES)
    assert best.kept in (frozenset({1}), frozenset({2}))
    failed = tried[frozenset({1, 2})].failure
    assert failed.startswith("c's gain moves by 10.0 of its σ when b is left out")


def test_greedy_beyond_the_exact_search_drops_the_worst_gain_first():
    # 8 free gains (> EXACT_SEARCH_MAX): each of 7 and 6 alone spoils the separation
    def ratio(kept):
        return 0.3 + 0.3 * (7 in kept) + 0.25 * (6 in kept)

    best, tried = partial.search_subsets(range(8), made_up(ratio), NAMES)
    assert best.kept == frozenset(range(6))
    assert len(tried) == 8 + 7 + 6  # a step of 8 removals, one of 7; the answer's 5-subsets
    assert partial.search_subsets(range(8), made_up(lambda k: 0.9), NAMES)[0] is None


# --- the big arm --------------------------------------------------------------------------
@pytest.fixture(scope="module")
def big_arm():
    truth = big_arm_truth()
    return load_robot(str(UR10_FILE)), truth, simulate_pair(1, SECONDS, truth=truth,
                                                            timestep=STEP)


# The paper's TLS (all of W_tot's columns noisy, eqs. 33-36) leaves this case unseparated: the
# subset search is tested on it. The per-joint TLS (the default) answers it whole (last test).
PAPER_TLS = IdentifyOptions.of(tls_noisy_columns="all", cross_check="none")


@pytest.fixture(scope="module")
def answered(big_arm):
    model, _, pair = big_arm
    return identify_records(pair_records(pair), model=model, options=PAPER_TLS)


def test_before_the_full_set_is_not_separated(big_arm):
    """The case: today's all-or-nothing answer exits 2 (eq. 37)."""
    model, _, pair = big_arm
    with pytest.raises(ExcitationError, match=r"not separated \(s_c/s_c-1 = 0\.\d+ > 0\.5"):
        identify_records(pair_records(pair), model=model,
                         options=PAPER_TLS.replace(partial_answers=False))


def test_the_subset_is_answered_within_3_sigma(big_arm, answered):
    _, truth, _ = big_arm
    res = answered
    g_true = truth.drive_array("g_tau")
    assert not res.complete
    determined = [(g, t) for g, t in zip(res.drive_gains, g_true) if g.determined]
    assert len(determined) >= 2
    for g, t in determined:  # the honest σ covers the error
        assert abs(g.value / t - 1) <= 3 * g.rel_std < 0.05, (g.name, g.value / t - 1, g.rel_std)
    doc = res.to_json()
    for g in doc["drive_gains"]:
        assert g["determined"] is (g["value"] is not None)
        assert g["determined"] or g["reason"]


def test_the_left_out_gains_say_why(answered):
    res = answered
    why = {g.name: g.reason for g in res.drive_gains if not g.determined}
    # the base axis: no gravity, the payload's inertia too small beside the arm's
    assert why["shoulder_pan_joint"].startswith(
        "shoulder_pan_joint not fixed beside the determined gains: with it, the two smallest "
        "singular values of W_tot are not separated (s_c/s_c-1 = ")
    # the last axis: the payload's CoM 2.5 cm off it
    assert "with it, the payload adds almost no torque on wrist_3_joint" in \
        why["wrist_3_joint"]
    # the elbow: with it, the answer depends on the rows' weights beyond noise (the 1e-4 rad
    # print at 90.9 Hz: a model error a smaller system amplifies)
    assert "gain moves by" in why["elbow_joint"] and \
        "between weighted and unweighted rows" in why["elbow_joint"]
    assert why["elbow_joint"].endswith("log positions finer than their print, or at a higher rate")
    assert why["wrist_3_joint"].endswith("record more motion of that joint with the payload on, "
                                         "or a heavier payload off its axis")
    assert any(w.startswith("partial answer: ") for w in res.warnings)


def test_nothing_separated_exits_with_the_real_reason(big_arm):
    """10 % current noise: no subset of the gains is separated with honest σ; the error says
    why for each gain and names eq. 37 and the subsets tried."""
    model, truth, _ = big_arm
    noisy = dataclasses.replace(truth, current_noise_fraction=0.10)
    pair = simulate_pair(1, SECONDS, truth=noisy, timestep=STEP)
    with pytest.raises(ExcitationError) as exc:
        identify_records(pair_records(pair), model=model, options=PAPER_TLS)
    msg = str(exc.value)
    assert msg.startswith("no drive gain is determined: ") and "\n" not in msg
    assert "not separated (s_c/s_c-1 = " in msg and "eq. 37" in msg
    assert "; nor is any subset of the gains of " in msg


def test_repeated_records_of_the_same_robot_agree_within_their_sigma(big_arm, answered):
    """Another pair (other trajectories and noise): the gains both answers determine agree
    within 3 σ of their difference."""
    model, truth, _ = big_arm
    other = simulate_pair(2, SECONDS, truth=truth, timestep=STEP)
    a, b = answered, identify_records(pair_records(other), model=model, options=PAPER_TLS)
    both = [(x, y) for x, y in zip(a.drive_gains, b.drive_gains) if x.determined and y.determined]
    assert both
    for x, y in both:
        sigma = np.hypot(x.value * x.rel_std, y.value * y.rel_std)
        assert abs(x.value - y.value) <= 3 * sigma, (x.name, x.value, y.value, sigma)


def test_the_per_joint_tls_answers_the_big_arm_whole_within_3_sigma(big_arm):
    """The default TLS (each current column scaled by its own noise, iterated: solve/tls.py)
    separates what the paper's TLS could not here: every gain determined, each within 3 of its
    σ of the plant's (measured 2026-12-06: within 1.2 σ on two pairs)."""
    model, truth, pair = big_arm
    res = identify_records(pair_records(pair), model=model)
    assert res.complete
    for g, t in zip(res.drive_gains, truth.drive_array("g_tau")):
        assert abs(g.value / t - 1) <= 3 * g.rel_std < 0.05, (g.name, g.value / t - 1, g.rel_std)
