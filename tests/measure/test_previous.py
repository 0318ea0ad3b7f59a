"""A previous model (``--from-model``) keeps answering only while each verification brings the
split down fast enough to reach the acceptance in the iterations left; otherwise the run measures
the local design. Each outcome of ``PreviousModel.judge``, on verifications whose splits are
given (the judgement reads only the status, the split and the sweep)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from sysid_core.errors import ConfigError
from sysid_core.measure.previous import PRIOR_CONTRACTION, PreviousModel, check_prior
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
    assert "did not bring the split down (not verified)" in str(
        previous().judge(verification(None), 3)
    )


def test_a_split_that_fell_fast_enough_keeps_it_and_anchors_on_the_window() -> None:
    prior = previous()
    assert prior.judge(verification(0.050), 3) is None  # the first verification: nothing to compare
    assert prior.judge(verification(0.002), 3) is None  # 25 times smaller: it reaches 1 mHz
    assert prior.last_split == pytest.approx(0.002) and len(prior.windows) == 2


def test_a_split_that_did_not_contract_ends_it() -> None:
    prior = previous()
    prior.judge(verification(0.050), 3)
    why = prior.judge(verification(0.050 * (PRIOR_CONTRACTION + 0.1)), 3)
    assert why is not None and "did not bring the split down (30 mHz)" in why


def test_a_split_that_falls_too_slowly_for_the_iterations_left_ends_it() -> None:
    prior = previous()
    prior.judge(verification(0.080), 1)
    why = prior.judge(verification(0.030), 1)  # 0.030 · (0.030/0.080) = 11 mHz after 1 more
    assert why is not None and "too slowly" in why
    again = previous()
    again.judge(verification(0.080), 6)
    assert again.judge(verification(0.030), 6) is None  # six iterations: 0.008 mHz at that rate


def test_a_previous_model_of_other_electrodes_is_refused() -> None:
    model = SimpleNamespace(electrodes=["B1", "B3"])
    with pytest.raises(ConfigError, match=r"electrodes \['B1', 'B3'\], the run tunes"):
        check_prior(model, ["B1", "B2"])  # type: ignore[arg-type]
