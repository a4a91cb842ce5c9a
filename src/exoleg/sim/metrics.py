"""What a walking run is judged by: the true contact events (from the noise-free contact
forces, the detector's definitions without its thresholds on counts or its debounce)
and the table of detected against true events (:func:`detection_table`)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from exoleg.control import gait_phase as gp

if TYPE_CHECKING:
    from exoleg.sim.walk import WalkResult

F64 = NDArray[np.float64]

#: A region of the foot is loaded, for the true events, above this normal force, N.
TRUE_CONTACT_N = 5.0


def true_events(force: F64, threshold: float = TRUE_CONTACT_N, dt: float = 1e-3,
                min_swing: float = 0.15, min_stance: float = 0.15) -> NDArray[np.int64]:
    """Event bits (IC 1, FF 2, HO 4, TO 8) per sample from contact forces (N, 4), sampled
    every ``dt`` s: the detector's definitions on the true forces, without noise,
    normalisation or debounce; a stride's contact (IC) needs ``min_swing`` s without one
    before it, its toe off ``min_stance`` s after its IC (a toe tapping the belt in early
    swing is not a stride)."""
    heel = force[:, 0] > threshold
    fore = force[:, 1:].max(axis=1) > threshold
    out = np.zeros(len(force), dtype=np.int64)
    phase = 0  # swing
    k_ic = k_to = -10**9
    for k in range(len(force)):
        h, f = heel[k], fore[k]
        if phase == 0:
            if (h or f) and (k - k_to) * dt >= min_swing:
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



def detection_table(results: list[WalkResult], window: float = 0.2) -> list[dict[str, Any]]:
    """Detected against true events over runs: per event, the number of true events, the
    mean and worst timing error (detected - true, s), missed and false rates. A detected
    event matches the nearest true event of its kind within ``window`` s."""
    rows = []
    for bit, name in gp.EVENT_NAMES.items():
        errs: list[float] = []
        n_true = n_det = missed = false = 0
        for r in results:
            walking = r.t >= r.walk_start
            tt = r.t[walking & ((r.true_events() & bit) > 0)]
            td = r.t[walking & ((r.events & bit) > 0)]
            n_true += len(tt)
            n_det += len(td)
            used = np.zeros(len(td), dtype=bool)
            for x in tt:
                cand = np.where(~used & (np.abs(td - x) <= window))[0]
                if not len(cand):
                    missed += 1
                    continue
                j = cand[np.argmin(np.abs(td[cand] - x))]
                used[j] = True
                errs.append(float(td[j] - x))
            false += int((~used).sum())
        e = np.array(errs)
        rows.append({"event": name, "true": n_true, "detected": n_det,
                     "mean_error_ms": float(1e3 * e.mean()) if len(e) else float("nan"),
                     "mean_abs_error_ms": float(1e3 * np.abs(e).mean()) if len(e) else float("nan"),
                     "worst_error_ms": float(1e3 * e[np.argmax(np.abs(e))]) if len(e)
                     else float("nan"),
                     "missed_rate": missed / n_true if n_true else float("nan"),
                     "false_rate": false / n_det if n_det else float("nan")})
    return rows
