"""Parameters as data: typed records and the loaders of the package's data files."""

from exoleg.params.records import JOINTS, LINKS, Actuator, Gains, Link, RangeOfMotion

__all__ = ["JOINTS", "LINKS", "Actuator", "Gains", "Link", "RangeOfMotion"]
