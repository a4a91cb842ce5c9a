"""Euler-Lagrange derivation of a planar serial chain with SymPy (paper section 4, eqs 15-19).

The chain hangs from a fixed joint at the origin (the swing model of the
paper). Link ``i`` turns by ``q_i`` relative to link ``i-1`` plus a constant
D-H offset (paper Table 3: -pi/2, 0, +pi/2 for hip, knee, ankle); its frame has
x along the link. Each link has five parameters, kept symbolic:

``m_i`` mass, ``a_i`` length, ``cx_i``, ``cy_i`` COM in the link frame measured
from the proximal joint, ``I_i`` centroidal inertia about z; after the links, one per
joint: ``arm_i``, the armature -- the actuator's rotor (and gear input) inertia
reflected through its gear, N^2 J, which adds ``1/2 arm_i dq_i^2`` to T (the rotor
turns N times as fast as the joint; the link's own rotation is negligible beside
it); and ``g``.

From the kinetic energy T and potential energy V (gravity along -y):

* ``M = d^2 T / d dq^2`` (eq 17),
* ``C_kj = sum_i c_ijk dq_i`` with Christoffel symbols
  ``c_ijk = 1/2 (dM_kj/dq_i + dM_ki/dq_j - dM_ij/dq_k)`` (eq 18), so that
  ``Mdot - 2C`` is skew-symmetric,
* ``G = dV / dq`` (eq 19).

This runs only when kernels are (re)generated (``python -m exoleg.dynamics.codegen``)
and in the test that proves the shipped kernels match a fresh derivation;
never at run time.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import sympy as sp

#: Parameters per link, in the order of the parameter vector ``p``.
LINK_PARAMS = ("m", "a", "cx", "cy", "I")
#: Parameters per joint, after every link's: the armature (reflected rotor inertia).
JOINT_PARAMS = ("arm",)


@dataclass(frozen=True)
class Derivation:
    """Symbolic equations of motion of an ``n``-link planar chain.

    ``p`` is ordered link by link as :data:`LINK_PARAMS` (5 n symbols), then the n
    armatures (:data:`JOINT_PARAMS`).
    """

    n: int
    offsets: tuple[float, ...]
    q: tuple[sp.Symbol, ...]
    dq: tuple[sp.Symbol, ...]
    p: tuple[sp.Symbol, ...]
    g: sp.Symbol
    M: sp.Matrix
    C: sp.Matrix
    G: sp.Matrix
    Mdot: sp.Matrix
    T: sp.Expr
    V: sp.Expr
    #: the kinematics: absolute link angles; the joints' points (n + 1: the base joint at
    #: the origin, ..., the last link's tip); the links' COMs; a point (px, py) fixed in
    #: the last link's frame; the height moment of the links' mass, Y = sum m_i y_ci
    phi: tuple[sp.Expr, ...]
    joints: tuple[sp.Matrix, ...]
    coms: tuple[sp.Matrix, ...]
    point_local: tuple[sp.Symbol, sp.Symbol]
    point: sp.Matrix
    Y: sp.Expr


def _offset(value: float) -> sp.Expr:
    """A D-H offset as an exact multiple of pi/2 where it is one (keeps trig exact)."""
    k = sp.nsimplify(value / float(sp.pi / 2), rational=True)
    if k.is_integer:
        return k * sp.pi / 2
    return sp.Float(value, 17)


def derive(offsets: Sequence[float], simplify: bool = True) -> Derivation:
    """Derive M, C, G, Mdot, T and V for a chain with these D-H joint offsets (rad)."""
    n = len(offsets)
    q = sp.symbols(f"q0:{n}", real=True)
    dq = sp.symbols(f"dq0:{n}", real=True)
    links = tuple(sp.Symbol(f"{name}{i}", real=True) for i in range(n) for name in LINK_PARAMS)
    armature = tuple(sp.Symbol(f"arm{i}", real=True) for i in range(n))
    p = links + armature
    g = sp.Symbol("g", real=True)
    m, a, cx, cy, inertia = (links[k::5] for k in range(5))

    phi = []  # absolute link angles
    acc: sp.Expr = sp.Integer(0)
    for i in range(n):
        acc = acc + q[i] + _offset(offsets[i])
        phi.append(acc)

    joint = sp.Matrix([0, 0])
    joints = [joint]
    coms = []
    T: sp.Expr = sp.Integer(0)
    V: sp.Expr = sp.Integer(0)
    Y: sp.Expr = sp.Integer(0)
    dqv = sp.Matrix(dq)
    for i in range(n):
        c, s = sp.cos(phi[i]), sp.sin(phi[i])
        com = joint + sp.Matrix([c * cx[i] - s * cy[i], s * cx[i] + c * cy[i]])
        coms.append(com)
        v = com.jacobian(q) * dqv
        omega = sum(dq[: i + 1])
        T += sp.Rational(1, 2) * m[i] * (v.T * v)[0] + sp.Rational(1, 2) * inertia[i] * omega**2
        V += m[i] * g * com[1]
        Y += m[i] * com[1]
        joint = joint + a[i] * sp.Matrix([c, s])
        joints.append(joint)
    T += sum(sp.Rational(1, 2) * armature[i] * dq[i] ** 2 for i in range(n))

    M = sp.zeros(n, n)
    for j in range(n):
        for k in range(j, n):
            e = sp.expand(sp.diff(T, dq[j], dq[k]))
            if simplify:
                e = sp.collect(sp.trigsimp(e), inertia)
            M[j, k] = M[k, j] = e

    C = sp.zeros(n, n)
    for k in range(n):
        for j in range(n):
            C[k, j] = sum(
                sp.Rational(1, 2)
                * (sp.diff(M[k, j], q[i]) + sp.diff(M[k, i], q[j]) - sp.diff(M[i, j], q[k]))
                * dq[i]
                for i in range(n)
            )
    G = sp.Matrix([sp.diff(V, qi) for qi in q])
    Mdot = M.applyfunc(lambda e: sum(sp.diff(e, q[i]) * dq[i] for i in range(n)))
    px, py = sp.symbols("px py", real=True)
    c, s = sp.cos(phi[-1]), sp.sin(phi[-1])
    point = joints[n - 1] + sp.Matrix([c * px - s * py, s * px + c * py])
    return Derivation(n=n, offsets=tuple(float(o) for o in offsets), q=q, dq=dq, p=p, g=g,
                      M=M, C=C, G=G, Mdot=Mdot, T=T, V=V, phi=tuple(phi),
                      joints=tuple(joints), coms=tuple(coms), point_local=(px, py),
                      point=point, Y=Y)


#: The inertial parameters the torques are linear in, per link (``barycentric``: mass,
#: the first moments m cx and m cy in the link frame, the inertia about the proximal
#: joint I + m (cx^2 + cy^2)), then per joint the armature -- the columns of the
#: regressor (:func:`regressor`).
BARYCENTRIC = ("m", "MX", "MY", "ZZ")


@dataclass(frozen=True)
class Regressor:
    """tau = Y(q, dq, ddq) pi for the chain of ``d``: ``Y`` (n, 5 n), its columns the
    parameters ``pi`` -- link by link :data:`BARYCENTRIC`, then the n armatures -- and
    the joint accelerations ``ddq`` it takes besides ``d``'s q and dq."""

    Y: sp.Matrix
    pi: tuple[sp.Symbol, ...]
    ddq: tuple[sp.Symbol, ...]


def regressor(d: Derivation) -> Regressor:
    """The chain's joint torques as linear in its inertial parameters. The energies are
    written in them directly: with c = (cx, cy) in link i's frame, R(phi_i) its rotation
    and w_i its absolute rate, the link's centre of mass moves at v_j + w_i R'(phi_i) c,
    so that T_i = 1/2 m v_j^2 + w_i v_j . R' (MX, MY) + 1/2 ZZ w_i^2 and V_i = g (m y_j +
    [R (MX, MY)]_y) -- no division by m to cancel -- and Lagrange's equations give tau;
    Y is its Jacobian in pi."""
    n = d.n
    per = [sp.symbols(f"{name}0:{n}", real=True) for name in BARYCENTRIC]
    arm = d.p[len(LINK_PARAMS) * n:]
    ddq = sp.symbols(f"ddq0:{n}", real=True)
    dqv = sp.Matrix(d.dq)
    T: sp.Expr = sp.Integer(0)
    V: sp.Expr = sp.Integer(0)
    for i in range(n):
        m, mx, my, zz = (p[i] for p in per)
        j = d.joints[i]
        vj = j.jacobian(d.q) * dqv
        w = sum(d.dq[: i + 1])
        c, s = sp.cos(d.phi[i]), sp.sin(d.phi[i])
        turned = sp.Matrix([-s * mx - c * my, c * mx - s * my])  # R'(phi) (MX, MY)
        T += (sp.Rational(1, 2) * m * (vj.T * vj)[0] + w * (vj.T * turned)[0]
              + sp.Rational(1, 2) * zz * w**2)
        V += d.g * (m * j[1] + s * mx + c * my)
    T += sum(sp.Rational(1, 2) * arm[i] * d.dq[i] ** 2 for i in range(n))
    tau = []
    for k in range(n):
        dT = sp.diff(T, d.dq[k])
        tau.append(sp.expand(sum(sp.diff(dT, d.dq[i]) * ddq[i] + sp.diff(dT, d.q[i]) * d.dq[i]
                                 for i in range(n)) - sp.diff(T, d.q[k]) + sp.diff(V, d.q[k])))
    pi = tuple(p[i] for i in range(n) for p in per) + tuple(arm)
    return Regressor(Y=sp.Matrix(tau).jacobian(pi), pi=pi, ddq=ddq)
