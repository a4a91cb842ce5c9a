"""What every run's result shares: named columns, and writing them out."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    import pyarrow as pa


class TimeSeries:
    """A run's result: :meth:`columns` (named 1-D arrays, SI units) as an Arrow table,
    CSV (exact round trip) or Parquet, each file written whole or not at all."""

    def columns(self) -> dict[str, NDArray[np.float64]]:
        raise NotImplementedError

    def table(self) -> pa.Table:
        """:meth:`columns` as an Arrow table."""
        import pyarrow as pa

        return pa.table(self.columns())

    def to_csv(self, path: str | Path) -> Path:
        """:meth:`columns` as CSV (:func:`exoleg.io.write_csv_table`)."""
        from exoleg.io import write_csv_table

        return write_csv_table(self.table(), path)

    def to_parquet(self, path: str | Path) -> Path:
        """:meth:`columns` as Parquet (:func:`exoleg.io.write_parquet_table`)."""
        from exoleg.io import write_parquet_table

        return write_parquet_table(self.table(), path)
