"""Closed-form leg columns and component-first kinematics (model/orthoglide/leg_closed_form.py)
against
the generic Newton-Euler recursion (idim.leg_columns, kinematics.tree_state)."""
from __future__ import annotations

import numpy as np
import pytest

from orthoglide_ident.errors import SingularityError
from orthoglide_ident.model.orthoglide import idim
from orthoglide_ident.model.orthoglide.base import base_model, random_states
from orthoglide_ident.model.orthoglide.kinematics import tree_state
from orthoglide_ident.model.orthoglide.leg_closed_form import (
    CLOSED_FORM,
    closed_form_columns,
    leg_state,
)


def test_closed_forms_equal_the_generic_recursion():
    q, qd, qdd = random_states(3000, seed=5)
    state = tree_state(q, qd, qdd)
    wanted = set(CLOSED_FORM)
    generic = idim.leg_columns(state, wanted)
    for source in (state, leg_state(q, qd, qdd)[0]):
        fast = closed_form_columns(source, wanted)
        for k in wanted:
            scale = np.abs(generic[k]).max() + 1e-300
            assert np.abs(fast[k] - generic[k]).max() < 1e-13 * scale, k


def test_base_observation_block_equals_the_generic_path():
    bm = base_model()
    q, qd, qdd = random_states(2500, seed=6)
    fast = bm.observation_block(q, qd, qdd)
    slow = np.zeros_like(fast)
    for s in range(0, q.shape[0], idim.CHUNK):
        st = tree_state(q[s:s + idim.CHUNK], qd[s:s + idim.CHUNK], qdd[s:s + idim.CHUNK])
        slow[:-1, :, s:s + idim.CHUNK] = idim.regressor_columns(st, bm.columns)
        slow[-1, :, s:s + idim.CHUNK] = idim.platform_column(st)
    scale = np.abs(slow).max(axis=(1, 2), keepdims=True) + 1e-300
    assert np.abs((fast - slow) / scale).max() < 1e-13


def test_singular_states_raise_the_same_error():
    q = np.zeros((3, 3))
    q[1] = [0.218, 0.289, 0.274]  # the three bars nearly coplanar
    for f in (lambda: tree_state(q, q * 0, q * 0), lambda: leg_state(q, q * 0, q * 0)):
        with pytest.raises(SingularityError, match=r"\(sample 1\) is at a parallel singularity"):
            f()
