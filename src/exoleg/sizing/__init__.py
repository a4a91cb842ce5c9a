"""Fitting the device to a child: profile, dimensions, fit, personalized model, demand,
population."""

from exoleg.sizing.anthropometry import (
    Dimensions,
    EstimatorError,
    estimate_dimensions,
    estimator_errors,
    table1_estimate,
    table1_rule,
)
from exoleg.sizing.child import Child, DesignRangeWarning
from exoleg.sizing.fit import DeviceFit, Miss, fit_device
from exoleg.sizing.personal import personalized_leg

__all__ = ["Child", "DesignRangeWarning", "DeviceFit", "Dimensions", "EstimatorError", "Miss",
           "estimate_dimensions", "estimator_errors", "fit_device", "personalized_leg",
           "table1_estimate", "table1_rule"]
