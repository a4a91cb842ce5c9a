"""The true contact events of a walk: the gait-phase detector's definitions (initial
contact, foot flat, heel off, toe off) applied to the noise-free contact forces, without
its thresholds on counts or its debounce -- what the detected events are judged against
(:func:`exoleg.sim.metrics.detection_table`)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]


#: A region of the foot is loaded, for the true events, above this normal force, N.
TRUE_CONTACT_N = 5.0
#: The shortest stance, s: a stride's toe off comes no sooner after its contact, and a
#: shorter load is a touch of the belt in swing (:func:`loads`).
MIN_STANCE_S = 0.15


def true_events(force: F64, threshold: float = TRUE_CONTACT_N, dt: float = 1e-3,
                min_swing: float = 0.15, min_stance: float = MIN_STANCE_S,
                ahead: NDArray[np.bool_] | None = None) -> NDArray[np.int64]:
    """Event bits (IC 1, FF 2, HO 4, TO 8) per sample from contact forces (N, 4), sampled
    every ``dt`` s: the detector's definitions on the true forces, without noise,
    normalisation or debounce; a stride's contact (IC) needs ``min_swing`` s without one
    before it, its toe off ``min_stance`` s after its IC (a toe tapping the belt in early
    swing is not a stride); with ``ahead`` (per sample: the ankle ahead of the hip), a
    stride's contact is the foot landing ahead of the hip -- a toe scuffing the belt
    behind it in swing is not one."""
    heel = force[:, 0] > threshold
    fore = force[:, 1:].max(axis=1) > threshold
    land = np.ones(len(force), dtype=bool) if ahead is None else ahead
    out = np.zeros(len(force), dtype=np.int64)
    phase = 0  # swing
    k_ic = k_to = -10**9
    for k in range(len(force)):
        h, f = heel[k], fore[k]
        if phase == 0:
            if (h or f) and land[k] and (k - k_to) * dt >= min_swing:
                k_ic = k
                out[k] |= 1
                phase = 1
                if h and f:
                    out[k] |= 2
                    phase = 2
        elif not h and not f:
            if (k - k_ic) * dt >= min_stance:
                out[k] |= 8
                phase = 0
                k_to = k
        elif phase == 1 and h and f:
            out[k] |= 2
            phase = 2
        elif phase == 2 and f and not h:
            out[k] |= 4
            phase = 3
    return out


def _runs(mask: NDArray[np.bool_]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Where each run of True in ``mask`` begins and where it has ended (paired)."""
    edges = np.diff(np.concatenate([[False], mask, [False]]).astype(np.int8))
    return np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)


def loads(loaded: NDArray[np.bool_], dt: float = 1e-3, min_stance: float = MIN_STANCE_S
          ) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """The samples at which the foot's load begins (``loaded``: per sample, whether any
    region bears), split by how long it lasts: stances (``min_stance`` s or longer: the
    foot landing) and touches (shorter: the toe catching the belt in swing, a light foot
    chattering on it -- a trip, on a child); a short load still on at the record's end is
    neither."""
    on, off = _runs(loaded)
    stance = (off - on) * dt >= min_stance - 1e-9
    # a short load the record ends in may yet be a stance: neither
    return on[stance], on[~stance & (off < len(loaded))]


def touches(force: F64, t: F64, since: float = -np.inf) -> F64:
    """When the foot touched the belt in swing (s, from ``since``): a load of any region
    of ``force`` (samples, regions; N, sampled at ``t``) above :data:`TRUE_CONTACT_N`
    shorter than a stance (:func:`loads`), the foot having left the belt before it.
    Loads the sole never let go of between them (no sample with every region at zero)
    are one: a toe unloading through the threshold, rebounding above it on the sole's
    spring for a tick or two and then leaving, is its stance's end, not a touch."""
    bearing = force.max(axis=1)
    loaded = bearing > TRUE_CONTACT_N
    for a, b in zip(*_runs(bearing > 0.0), strict=True):
        k = np.flatnonzero(loaded[a:b])
        if len(k):
            loaded[a + k[0]:a + k[-1] + 1] = True
    at = t[loads(loaded, float(t[1] - t[0]))[1]]
    return at[at >= since]
