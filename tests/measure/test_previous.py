"""A previous model (``--from-model``) keeps answering only while verifying its answers is the
quicker way to the acceptance at the rate the verified split falls (the rule of a run without a
model, ``contraction.too_slow``); otherwise the run measures the local design. Each outcome of
``PreviousModel.judge``, on verifications whose splits are given (the judgement reads only the
status, the split and the sweep)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from sysid_core.errors import ConfigError
from sysid_core.measure.contraction import Costs
from sysid_core.measure.previous import PreviousModel, check_prior
from sysid_core.measure.verification import Verification

ACCEPTANCE = 0.001


def verification(split_hz: float | None) -> Verification:
    """A verification that measured ``split_hz`` (None: no sweep showed both modes)."""
    f = None if split_hz is None else np.array([4430.0, 4430.0 + split_hz])
    status = "failed" if split_hz is None else "verified"
    return Verification(status, f, [], SimpleNamespace(name="sweep"), None)  # type: ignore[arg-type]


def previous() -> PreviousModel:
    return PreviousModel(SimpleNamespace(electrodes=["B1", "B2"]), ACCEPTANCE)  # type: ignore[arg-type]


def test_a_failed_verification_ends_the_previous_model() -> None:
    why, note = previous().judge(verification(None), 3)
    assert "did not bring the split down (not verified)" in str(why) and note is None


def test_a_split_that_fell_fast_enough_keeps_it_and_anchors_on_the_window() -> None:
    prior = previous()
    assert prior.judge(verification(0.050), 3) == (None, None)  # the first: nothing to compare
    assert prior.judge(verification(0.002), 3) == (None, None)  # 25 times smaller: it reaches 1 mHz
    assert prior.last_split == pytest.approx(0.002) and len(prior.windows) == 2


def test_a_split_that_did_not_fall_ends_it() -> None:
    prior = previous()
    prior.judge(verification(0.050), 3)
    why, _ = prior.judge(verification(0.060), 3, low_hz=0.040)  # its window resolves it
    assert why is not None and "did not fall (50 to 60 mHz)" in why
    assert len(prior.windows) == 1  # the window that did not help anchors nothing


def test_a_split_that_falls_too_slowly_for_the_iterations_left_ends_it() -> None:
    prior = previous()
    prior.judge(verification(0.080), 1)
    why, _ = prior.judge(verification(0.030), 1)  # 0.030 · (0.030/0.080) = 11 mHz after 1 more
    assert why is not None and "after the 1 iteration(s) left" in why
    again = previous()
    again.judge(verification(0.080), 6)
    assert again.judge(verification(0.030), 6) == (None, None)  # 0.008 mHz after six at that rate


def test_verifying_goes_on_while_it_is_cheaper_than_the_local_design() -> None:
    """50 to 30 mHz: 7 more verifications at that rate reach 1 mHz (0.6⁷ · 30 = 0.84 mHz)."""
    cheap, dear = Costs(verify=10.0, design=40.0), Costs(verify=10.0, design=100.0)
    prior = previous()
    prior.judge(verification(0.050), 20)
    why, _ = prior.judge(verification(0.030), 20, cheap)  # 70 s against 40 + 10
    assert why is not None and "7 verifications it needs would cost 1.4 times" in why
    again = previous()
    again.judge(verification(0.050), 20)
    assert again.judge(verification(0.030), 20, dear) == (None, None)  # 70 s against 110


def test_a_rise_inside_the_windows_noise_keeps_the_model_and_says_so() -> None:
    """At the bench's noise floor two windows whose intervals overlap give no rate."""
    prior = previous()
    prior.judge(verification(0.0035), 3)
    why, note = prior.judge(verification(0.0038), 3, low_hz=0.0)  # 95 %: 0 to 10 mHz
    assert why is None and note is not None and "no rate to read" in note
    assert prior.last_split == pytest.approx(0.0038) and len(prior.windows) == 2
    # one that falls fast enough says nothing, resolved or not
    assert prior.judge(verification(0.0002), 3, low_hz=0.0) == (None, None)


def test_a_previous_model_of_other_electrodes_is_refused() -> None:
    model = SimpleNamespace(electrodes=["B1", "B3"])
    with pytest.raises(ConfigError, match=r"electrodes \['B1', 'B3'\], the run tunes"):
        check_prior(model, ["B1", "B2"])  # type: ignore[arg-type]
