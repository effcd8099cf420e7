"""The table of identification methods (identify/methods.py): every row solves, the CLI and the
checks follow the table, and a new row is all a new method needs besides its own module."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from synthetic import NAMES, TRUE_CHI, TRUE_GAINS, SyntheticModel, synthetic_record

from orthoglide_ident.cli import build_parser
from orthoglide_ident.errors import IdentificationError
from orthoglide_ident.identify import identify_records
from orthoglide_ident.identify.solve import methods
from orthoglide_ident.identify.solve.answer import solve_wls

MODEL = SyntheticModel()


@pytest.fixture(scope="module")
def records():
    kw = dict(amplitude=0.1, f_max=4.0)
    return [synthetic_record(20.0, 0.0, seed=1, noise=True, **kw),
            synthetic_record(20.0, 1.983, seed=2, noise=True, **kw)]


@pytest.mark.parametrize("name", sorted(methods.METHODS))
def test_every_method_of_the_table_solves_and_keeps_its_promise_about_the_gains(records, name):
    m = methods.METHODS[name]
    gains = list(TRUE_GAINS * 1.01) if m.gains_given else None
    res = identify_records(records, method=name, gains=gains, model=MODEL)
    assert res.method == name
    got = np.array([g.value for g in res.drive_gains])
    if m.gains_given:  # an input: handed back as given, the payload mass estimated
        assert np.array_equal(got, gains) and res.payloads
    else:  # identified: the truth within 4 of the result's own σ, which is below 2 %
        sigma = np.array([g.rel_std for g in res.drive_gains]) * got
        assert np.all(np.abs(got - TRUE_GAINS) < 4 * sigma) and np.all(sigma < 0.02 * got)


def test_an_unknown_method_names_the_table(records):
    with pytest.raises(IdentificationError, match="unknown method 'ml': use tls or wls or iv"):
        identify_records(records, method="ml", model=MODEL)
    assert methods.get(methods.DEFAULT_METHOD) is methods.METHODS["tls"]


def test_the_cli_offers_the_table():
    parser = build_parser()
    for name in methods.METHODS:
        assert parser.parse_args(["identify", "B", "--method", name]).method == name
    with pytest.raises(SystemExit):
        parser.parse_args(["identify", "B", "--method", "ml"])


def test_a_new_row_is_all_the_pipeline_needs(records, monkeypatch):
    """A method registered in the table (here WLS under another name, the true gains given) runs
    through the offline path unchanged: the checks and the dispatch read the table. Expected: the
    generator's own truth (synthetic.TRUE_CHI and the 1.983 kg it loaded), not another run of the
    code, each within 4 of the answer's σ."""
    calls = []
    row = dataclasses.replace(methods.METHODS["wls"], name="wls_again",
                              solve=lambda *a: calls.append(a) or solve_wls(*a))
    monkeypatch.setitem(methods.METHODS, "wls_again", row)
    res = identify_records(records, method="wls_again", gains=list(TRUE_GAINS), model=MODEL)
    assert len(calls) == 1  # the row's own solver ran
    truth = dict(zip(NAMES, TRUE_CHI))
    got = {p.name: p for p in res.parameters}
    assert set(got) == set(NAMES)
    for name, p in got.items():
        assert abs(p.value - truth[name]) < 4 * p.rel_std * abs(p.value), (name, p)
    (mass,) = res.payloads
    assert abs(mass.value - 1.983) < 4 * mass.rel_std * mass.value
