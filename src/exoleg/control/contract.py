"""The tick contract as the controllers see it: the records and enumerations are declared
in :mod:`exoleg.tick` (a leaf every floor may import) and re-exported here for one
release; what is the controllers' own is the page's vocabulary (:func:`vocabulary`):
which commands apply in each mode and which support modes the walking controller has.
"""

from __future__ import annotations

from typing import Any

from exoleg.control.supervisor import APPLIES
from exoleg.control.transparency import SUPPORT_APPLIES, SUPPORT_COMMANDS
from exoleg.layout import enum_table
from exoleg.params.records import JOINTS
from exoleg.tick import (  # noqa: F401  (the old import path, for one release)
    ARMED_MODES,
    EVENT_NAMES,
    LABELS,
    LIMITED_TEXT,
    OUTPUT,
    PHASE_NAMES,
    SENSOR_POINTS,
    SENSORS,
    SOURCE_NAMES,
    WALKING_MODES,
    Command,
    Controller,
    Event,
    Fault,
    Limited,
    Mode,
    Phase,
    Source,
    SupportMode,
    TickRecords,
    name_of,
    output_columns,
    output_kinds,
)


def vocabulary() -> dict[str, Any]:
    """What a page needs to show the tick's numbers, taken from the enumerations
    themselves (served to the page, which keeps no table of its own): each enumeration's
    names by value, the texts of the phases, events and safety bits, the joints and the
    FSR points, the commands that apply in each mode (``applies``) and the modes in
    which the drives are enabled (``armed``)."""
    out: dict[str, Any] = {k: {str(v): n for n, v in t.items()}
                           for k, t in enum_table(Mode, Command, Phase, Event, Fault,
                                                  Limited, SupportMode).items()}
    out["text"] = {"Phase": {str(int(k)): v for k, v in PHASE_NAMES.items()},
                   "Event": [[int(k), v] for k, v in EVENT_NAMES.items()],
                   "Source": {str(int(k)): v for k, v in SOURCE_NAMES.items()},
                   "Limited": [[int(k), v] for k, v in LIMITED_TEXT.items()]}
    out["joints"], out["sensors"] = list(JOINTS), list(SENSOR_POINTS)
    out["applies"] = {str(int(m)): [c.name.lower() for c in cs] for m, cs in APPLIES.items()}
    # the walking controller's support modes (a law other than its refuses them)
    out["support_applies"] = [m.name for m in SUPPORT_APPLIES]
    out["support_commands"] = [c.name.lower() for c in SUPPORT_COMMANDS]
    out["armed"] = sorted(m.name for m in ARMED_MODES)
    return out
