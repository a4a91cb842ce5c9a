"""Records as the log's flat columns (exoleg.layout.float_columns).

Reference: numpy's own ``structured_to_unstructured(records, dtype=float64)``, which the
session's drain used before (the log's rows must not change by a bit)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.lib.recfunctions import structured_to_unstructured

from exoleg.layout import column_names, float_columns
from exoleg.runtime.sim_backend import RECORD
from exoleg.tick import OUTPUT


@pytest.mark.parametrize("dtype", [OUTPUT, RECORD], ids=["the controller's output",
                                                         "the simulated device's record"])
def test_the_columns_are_numpys_to_the_bit(dtype: np.dtype) -> None:
    rng = np.random.default_rng(7)
    records = np.zeros(64, dtype)
    records.view(np.uint8)[:] = rng.integers(0, 256, records.nbytes)  # NaNs, any integer
    picked = records[[5, 1, 63, 5]]  # as the drain picks ticks from the ring
    ours, numpys = float_columns(picked), structured_to_unstructured(picked, dtype=np.float64)
    assert ours.shape == numpys.shape == (4, len(column_names(dtype)))
    assert np.array_equal(ours.view(np.int64), numpys.view(np.int64))
    assert float_columns(records[:0]).shape == (0, len(column_names(dtype)))


@pytest.mark.parametrize("fields", [[("a", np.float32)], [("a", np.float64), ("b", np.int8)]],
                         ids=["4-byte float", "padding"])
def test_a_record_not_of_packed_8_byte_numbers_is_refused(fields: list[tuple[str, type]]) -> None:
    dtype = np.dtype(fields, align=True)
    with pytest.raises(ValueError, match="not a packed 8-byte number|padding"):
        float_columns(np.zeros(2, dtype))
