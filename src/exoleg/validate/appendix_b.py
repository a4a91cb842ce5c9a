"""Paper Appendix B, typed in as printed: the numeric M (A30-A38), C (A40-A48) and G (A50-A52).

This is reference data for validation only -- the paper's own numbers, with
their five-significant-digit rounding -- never used to simulate. Appendix B
corresponds to Table 5's simplified column with a3 = 0.235 m and g = 9.81
(``docs/conventions.md``). q = (theta1, theta2, theta3) rad.
"""

from __future__ import annotations

from math import cos, sin

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]


def M(q: F64) -> F64:
    """Eqs A30-A38."""
    _, t2, t3 = q
    a = cos(t2 + t3 + 0.80585)
    b = cos(t3 + 0.80585)
    c = cos(t2 - 0.00094788)
    m11 = 0.028026 * a + 0.029804 * b + 0.2928 * c + 0.42005
    m12 = 0.014013 * a + 0.029804 * b + 0.1464 * c + 0.13908
    m13 = 0.014013 * a + 0.014902 * b + 0.0027942
    m22 = 0.029804 * b + 0.13908
    m23 = 0.014902 * b + 0.0027942
    m33 = 0.0027942
    return np.array([[m11, m12, m13], [m12, m22, m23], [m13, m23, m33]])


def C(q: F64, dq: F64) -> F64:
    """Eqs A40-A48."""
    _, t2, t3 = q
    d1, d2, d3 = dq
    k2 = cos(t2 + 1.5698)
    k3 = cos(t3 - 0.76495)
    k23 = cos(t2 + t3 - 0.76495)
    s3 = 0.010751 * cos(t3) + 0.01032 * sin(t3)
    s23 = 0.010109 * cos(t2 + t3) + 0.009704 * sin(t2 + t3)
    c11 = 0.1464 * d2 * k2 - 0.014902 * d3 * k3 - 0.014013 * (d2 + d3) * k23
    c12 = 0.1464 * (d1 + d2) * k2 - 0.014902 * d3 * k3 - 0.014013 * (d1 + d2 + d3) * k23
    c13 = -2.7041 * (0.0051821 * k23 + 0.0055108 * k3) * (d1 + d2 + d3)
    c21 = d1 * (s23 - 0.00013877 * cos(t2) + 0.1464 * sin(t2)) - 1.0 * d3 * s3
    c22 = -0.014902 * d3 * k3
    c23 = -0.014902 * k3 * (d1 + d2 + d3)
    c31 = d1 * (s23 + s3) + d2 * s3
    c32 = 0.014902 * k3 * (d1 + d2)
    return np.array([[c11, c12, c13], [c21, c22, c23], [c31, c32, 0.0]])


def G(q: F64) -> F64:
    """Eqs A50-A52."""
    t1, t2, t3 = q
    g3 = 0.45655 * cos(t1 + t2 + t3 - 0.76495)
    g2 = g3 - 4.7698 * cos(t1 + t2 + 1.5698)
    g1 = g2 + 10.08 * cos(t1 - 1.5704)
    return np.array([g1, g2, g3])
