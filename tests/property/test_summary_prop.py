"""Property tests for the summary's figures: its percentiles are numpy's."""

from __future__ import annotations

import warnings

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from prezence.summary import _DECILES, _percentiles

values = st.lists(
    st.one_of(
        st.floats(allow_nan=True, allow_infinity=True),
        st.sampled_from([0.0, -0.0, 1.0, -1.0]),  # ties and signed zeros
    ),
    min_size=1,
    max_size=60,
)


@given(values)
def test_the_summarys_percentiles_are_numpys_and_never_a_negative_zero(xs: list[float]) -> None:
    # session 24 took np.percentile out of a replay (its np.unique imports numpy.ma); the p10,
    # p50 and p90 in summary.json must stay what numpy says, and never "-0.0"
    a = np.array(xs, dtype=float)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # inf - inf in numpy's interpolation
        want = np.percentile(a, [10, 50, 90])
        got = _percentiles(a, _DECILES)
    assert np.array_equal(got, want, equal_nan=True)
    assert not np.signbit(got[got == 0.0]).any()
