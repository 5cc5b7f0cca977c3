"""The shared validation's messages: what was received is shown as a value (quoted when it is a
string the user gave) or, when it is a description of an array, as written."""

import numpy as np
import pytest

from windnav._validate import batch_array, positive_float


def test_a_description_of_the_array_is_not_quoted():
    with pytest.raises(ValueError) as info:
        batch_array(np.ones((3, 1)), "wind", "f", (2,))
    assert str(info.value).endswith("Got shape (3, 1) instead.")
    with pytest.raises(ValueError) as info:
        batch_array(np.ones((3, 2)), "wind", "f", (2,), batch=2)
    assert str(info.value).endswith("must be a batch of 2. Got a batch of 3 instead.")
    with pytest.raises(ValueError) as info:
        batch_array([[np.nan, 1.0]], "wind", "f", (2,))
    assert str(info.value).endswith("Got non-finite entries instead.")


def test_a_value_the_user_gave_is_shown_as_its_repr():
    with pytest.raises(ValueError) as info:
        positive_float("fast", "speed", "f")
    assert str(info.value) == ("The 'speed' parameter of f must be a number. "
                               "Got 'fast' instead.")
    with pytest.raises(ValueError, match=r"Got -1\.5 instead\.$"):
        positive_float(-1.5, "speed", "f")
