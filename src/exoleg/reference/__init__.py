"""Joint references: anything with ``sample(t) -> (q_ref, dq_ref, ddq_ref)``, each (N, 3) rad."""

from exoleg.reference.steps import Reference, Steps

__all__ = ["Reference", "Steps"]
