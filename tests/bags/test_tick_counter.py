"""The recorder's streaming missing-sample count (bags.info.TickCounter) at any rate: judged
against the source's own step, it finds exactly the samples taken out of records at 1 kHz,
500 Hz and ~83 Hz on an uneven 10/12/14 ms clock (issue 47: 90 % 'missing' at ~93 Hz)."""
from __future__ import annotations

import pytest

from orthoglide_ident.bags.info import TickCounter, find_gaps
from tests.records_at_rates import RATES, stamps


@pytest.mark.parametrize("rate", list(RATES))
def test_counts_the_samples_taken_out(rate):
    st, truth = stamps(rate)
    c = TickCounter(1000.0)  # the recorder's default expected_rate, whatever the source's
    for s in st:
        c.add(int(s))
    c.finish()
    assert c.missing == truth == 7
    assert find_gaps(st).missing == truth  # and `info` agrees
    assert ("1000 Hz ticks" in c.describe()) == (rate == "1kHz"), c.describe()
    assert ("uneven" in c.describe()) == rate.startswith("uneven"), c.describe()


def test_before_the_change_a_100hz_source_was_mostly_missing():
    """The 1 kHz tick rule the recorder used counts ~11 'missing' ticks per 12 ms step."""
    from orthoglide_ident.ticks import missing_in_step

    st, truth = stamps("uneven_83Hz")
    ticks = sum(missing_in_step(int(b - a), 1e6) for a, b in zip(st[:-1], st[1:]))
    assert ticks > 10 * len(st) and truth == 7


def test_short_and_streamed_in_pieces():
    """Fewer steps than a window: the median step; the status's count never exceeds the end's."""
    st, _ = stamps("uneven_83Hz", n=20, drops=((10, 1),))
    c = TickCounter(1000.0)
    for s in st:
        c.add(int(s))
    assert c.missing == 0  # nothing judged yet: too few steps for a window
    c.finish()
    assert c.missing == 1
