"""What a fit found, typed: ``FittedModel.facts`` reads ``meta`` once, the same after a round
trip through ``model.nc``, and a fit's own facts are those of its law test and its data."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from sysid_core.model.facts import FitFacts, LawTest


def test_no_meta_means_nothing_found() -> None:
    facts = FitFacts.of({})
    assert facts.law is None and facts.trend_per_s is None and facts.fit_bias is None
    assert facts.time_span_s == 0.0 and not facts.from_model and facts.offsets == ()


@given(
    stat=st.floats(0.0, 1e3),
    threshold=st.floats(1.0, 100.0),
    tested=st.sampled_from(["split", "all"]),
)
def test_a_tested_law_says_which_side_of_its_threshold(
    stat: float, threshold: float, tested: str
) -> None:
    law = "quadratic" if stat > threshold else "linear"
    meta = {
        "stiffness_law": law,
        "law_statistic": stat,
        "law_threshold": threshold,
        "law_tested": tested,
    }
    found = FitFacts.of(meta).law
    assert found == LawTest(law, stat, threshold, tested)
    sign = ">" if law == "quadratic" else "<="
    assert f" {sign} " in found.describe() and found.describe().startswith(law)
    assert ("that split the modes" in found.describe()) is (tested == "split")


def test_an_untested_law_gives_its_reason() -> None:
    law = FitFacts.of({"stiffness_law": "linear", "law_test": "design does not identify L_p"}).law
    assert law is not None and law.describe() == "linear (design does not identify L_p)"


def test_a_fit_and_its_file_have_the_same_facts(tmp_path: Path) -> None:
    from sysid_cloverleaf import CloverleafGyro

    from sysid_core import fit, load_model
    from sysid_core.data import concat_experiments, experiment_from_measurement
    from sysid_core.measure.sweeps import design_experiments

    gyro = CloverleafGyro(seed=2)
    f = np.linspace(4385.0, 4445.0, 121)
    design = design_experiments(np.zeros(3), [0, 1], 1.0, (-10.0, 10.0), two_sided=True)
    parts = [
        experiment_from_measurement(gyro.measure(b, f), b, gyro.electrodes, 15.58, "cloverleaf")
        for b in design
    ]
    ds = concat_experiments(parts).sel(electrode=["B1", "B2"])
    model = fit(ds)
    facts = model.facts
    assert facts.law is not None and facts.law.law in ("linear", "quadratic")
    assert facts.law.statistic is not None and facts.law.threshold is not None
    assert facts.trend_per_s is None and not facts.from_model
    np.testing.assert_allclose(facts.fit_bias, design[:, :2], atol=1e-3)  # the DAC applies them
    assert facts.fit_time_s is not None and facts.fit_time_s >= 0
    model.save(tmp_path / "model.nc")
    again = load_model(tmp_path / "model.nc").facts
    assert again.law == facts.law
    np.testing.assert_array_equal(again.fit_bias, facts.fit_bias)


def test_a_trend_reads_as_a_matrix_with_its_span() -> None:
    trend = [[1e-3, 2e-4], [2e-4, -5e-4]]
    facts = FitFacts.of({"drift_trend": trend, "drift_trend_span_s": 5400.0, "time_span_s": 6e3})
    np.testing.assert_array_equal(facts.trend_per_s, np.array(trend))
    assert facts.trend_span_s == 5400.0 and facts.time_span_s == pytest.approx(6e3)
