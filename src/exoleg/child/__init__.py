"""The child as an actor: passive joint moments with contracture, spasticity and the
child's own effort (:mod:`exoleg.child.model`), the interaction torque the device's cuffs
transmit (:mod:`exoleg.child.interaction`) and the clinical tests on the simulated child
(:mod:`exoleg.child.assess`). See ``docs/child.md``."""

from exoleg.child.model import ChildModel, Spasticity
from exoleg.child.passive import Contracture, passive_moments, passive_record

__all__ = ["ChildModel", "Contracture", "Spasticity", "passive_moments", "passive_record"]
