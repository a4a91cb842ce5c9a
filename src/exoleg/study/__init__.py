"""Studies at scale: a sweep as data (:mod:`exoleg.study.spec`), its runs
(:mod:`exoleg.study.runs`: the child, the device variant, the controller and the walk
of each, judged by one row), run on Dask into one Parquet dataset
(:mod:`exoleg.study.engine`), and summarised over any two axes
(:mod:`exoleg.study.summary`)."""

from exoleg.study.engine import execute, read_results
from exoleg.study.spec import AXES, Study, load_study, parse_study

__all__ = ["AXES", "Study", "execute", "load_study", "parse_study", "read_results"]
