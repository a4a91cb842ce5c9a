"""Staged identification (Li et al. 2022): the device alone first -- its links and its
rotors, once for a device, with no child in it -- then the device with the child, the
device's share of the prior its own identification and the child the difference.

The leg's inertial parameters are additive per link (mass, first moments and inertia
about the joint of the child's segment and the device's link add), so the prior of the
second stage is the fitted leg with the device's model replaced by the device
identified, and its SDs the two shares' in quadrature: the child's from the tables
(:func:`~exoleg.identify.estimate.prior_sd` on the child's share), the device's from
its identification's posterior (``Identified.inertial_sd``). What the motion can tell of
the child -- their share of the base parameters -- is then the identified leg's less
the identified device's, not less a model of the device.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from exoleg.dynamics.kernels import N_INERTIAL, N_JOINTS
from exoleg.dynamics.model import LegModel
from exoleg.errors import ParameterError
from exoleg.identify.estimate import leg_of, prior_sd

F64 = NDArray[np.float64]


def child_share(leg: LegModel, device: LegModel) -> F64:
    """The child's share of ``leg``'s inertial parameters (the regressor's order, 15):
    ``leg``'s less the ``device``'s (both with the same geometry), the armatures zero."""
    if not np.allclose(leg.lengths, device.lengths, rtol=0, atol=1e-9):
        raise ParameterError("identify", "device", "identified with its links at "
                             f"{np.round(device.lengths, 4).tolist()} m; the leg's are "
                             f"{np.round(leg.lengths, 4).tolist()} m: identify the device "
                             "alone with its telescopes set for this child (--device-alone "
                             "--leg)")
    out: F64 = leg.inertial() - device.inertial()
    out[4 * N_JOINTS:] = 0.0
    return out


def staged_prior(fitted: LegModel, device_model: LegModel, device: LegModel,
                 device_sd: F64 | None) -> tuple[LegModel, F64]:
    """The second stage's prior: the ``fitted`` child + device leg (with the actuators)
    with ``device_model`` (the device alone as modelled) replaced by ``device`` (the
    device alone identified, at the same telescope settings; ``device_sd`` its
    parameters' SDs, ``Identified.inertial_sd``), and its SDs in :func:`prior_sd`'s
    layout."""
    sd_device = np.asarray(device_sd if device_sd is not None else [], dtype=np.float64)
    if sd_device.shape != (N_INERTIAL,) or not np.all(np.isfinite(sd_device)) \
            or np.any(sd_device <= 0):
        raise ParameterError("identify", "device", "holds no SDs of its parameters (an "
                             "identification of the device alone gives them)")
    child_share(fitted, device)  # the same telescope settings
    share = child_share(fitted, device_model)
    try:
        child = leg_of(fitted, share, name="the child's share")
    except ParameterError as e:
        raise ParameterError("identify", "--leg", f"less the device's model it leaves no "
                             f"child ({e.field}: {e.problem.split(':')[0]}): the stages need "
                             "a fitted leg of the child's segments and the device's parts "
                             "(exoleg fit --write-leg)") from None
    sd_child = prior_sd(child)
    sd_child[4 * N_JOINTS:] = 0.0
    pi = share + device.inertial()
    pi[4 * N_JOINTS:] = device.inertial()[4 * N_JOINTS:]
    prior = leg_of(fitted, pi, name=f"{fitted.name} on the identified device")
    sds: F64 = np.sqrt(sd_child**2 + sd_device**2)
    return prior, sds
