"""Code generation: symbolic equations -> common subexpressions -> numba kernels.

``python -m exoleg.dynamics.codegen`` derives the leg's equations
(:mod:`exoleg.dynamics.derive`, D-H offsets from the paper's Table 3 data file)
and writes ``_generated.py``, a shipped build product: plain scalar Python
compiled by numba with an on-disk cache, so neither SymPy nor the derivation
runs when exoleg is used. ``--check`` regenerates in memory and fails if the
shipped file differs; ``tests/validation/test_codegen.py`` also checks the
kernels numerically against a fresh derivation.

Every kernel takes the joint state ``q`` (and ``dq``) as float arrays of
length n, the parameter vector ``p`` (6 n floats: link by link
``m, a, cx, cy, I``, then the n joint armatures; see
:data:`exoleg.dynamics.derive.LINK_PARAMS`), ``g``
where gravity enters, and writes into a caller-owned ``out`` array.
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Sequence
from itertools import combinations_with_replacement
from pathlib import Path

import sympy as sp
from sympy.printing.pycode import PythonCodePrinter

from exoleg.dynamics.derive import (
    BARYCENTRIC,
    JOINT_PARAMS,
    LINK_PARAMS,
    Derivation,
    derive,
    regressor,
)

GENERATED = Path(__file__).with_name("_generated.py")


class _Printer(PythonCodePrinter):
    """Prints plain ``cos(x)``; small integer powers as products (faster under numba)."""

    def __init__(self) -> None:
        super().__init__({"fully_qualified_modules": False, "standard": "python3"})

    def _print_Pow(self, expr: sp.Pow, rational: bool = False) -> str:
        b, e = expr.as_base_exp()
        if e.is_Integer and 2 <= int(e) <= 3:
            s = self.parenthesize(b, 100)
            return "*".join([s] * int(e))
        return str(super()._print_Pow(expr, rational=rational))


_PRINTER = _Printer()


def _code(e: sp.Expr) -> str:
    return str(_PRINTER.doprint(e))


def _unpack(d: Derivation, used: set[sp.Basic], state: Sequence[str]) -> list[str]:
    """Lines that bind the symbols a kernel uses from its array arguments."""
    lines = []
    for name in state:
        syms = {"q": d.q, "dq": d.dq}.get(name)
        if syms is None:
            continue
        for i, s in enumerate(syms):
            if s in used:
                lines.append(f"{s} = {name}[{i}]")
    for i, s in enumerate(d.p):
        if s in used:
            lines.append(f"{s} = p[{i}]")
    return lines


def _trig(d: Derivation, exprs: list[sp.Expr]) -> tuple[list[sp.Expr], list[str]]:
    """Replace sin/cos of joint-angle sums by symbols built from one sin and cos per joint.

    ``sin(q0 + q1)`` becomes ``s_0_1 = s_0*c_1 + c_0*s_1`` and so on, so a kernel
    calls the trig functions only once per joint angle (the dominant cost).
    Returns the rewritten expressions and the preamble lines, in dependency order.
    """
    index = {s: i for i, s in enumerate(d.q)}
    sums: set[tuple[int, ...]] = set()
    for e in exprs:
        for f in e.atoms(sp.sin, sp.cos):
            terms = sp.Add.make_args(f.args[0])
            if all(t in index for t in terms):
                sums.add(tuple(sorted(index[t] for t in terms)))
    needed: set[tuple[int, ...]] = set()
    for key in sums:  # every prefix of a sum is built on the way
        for k in range(1, len(key) + 1):
            needed.add(key[:k])
        needed.update((i,) for i in key)
    lines, rep = [], {}
    for key in sorted(needed, key=lambda k: (len(k), k)):
        name = "_".join(map(str, key))
        if len(key) == 1:
            lines += [f"s_{name} = sin({d.q[key[0]]})", f"c_{name} = cos({d.q[key[0]]})"]
        else:
            a, b = "_".join(map(str, key[:-1])), str(key[-1])
            lines += [f"s_{name} = s_{a} * c_{b} + c_{a} * s_{b}",
                      f"c_{name} = c_{a} * c_{b} - s_{a} * s_{b}"]
        arg = sum(d.q[i] for i in key)
        rep[sp.sin(arg)] = sp.Symbol(f"s_{name}")
        rep[sp.cos(arg)] = sp.Symbol(f"c_{name}")
    return [e.xreplace(rep) for e in exprs], lines


def _body(d: Derivation, exprs: list[sp.Expr], targets: list[str],
          state: Sequence[str]) -> list[str]:
    """CSE the expressions and assign each to its target."""
    used: set[sp.Basic] = set()
    for e in exprs:
        used |= e.free_symbols
    exprs, trig = _trig(d, exprs)
    return _unpack(d, used, state) + trig + _cse(exprs, targets)


def _cse(exprs: list[sp.Expr], targets: list[str]) -> list[str]:
    """Common subexpressions as ``x<i>`` lines, then each expression assigned to its target."""
    subs, reduced = sp.cse(exprs, symbols=sp.numbered_symbols("x"), optimizations="basic")
    return ([f"{s} = {_code(v)}" for s, v in subs]
            + [f"{t} = {_code(v)}" for t, v in zip(targets, reduced, strict=True)])


def _composites(trig: list[str], exprs: list[sp.Expr]) -> list[str]:
    """The trig preamble's angle-sum lines (``s_0_1 = ...``) that ``exprs`` need."""
    needed = {str(s) for e in exprs for s in e.free_symbols}
    keep = []
    for ln in reversed(trig):
        lhs, rhs = ln.split(" = ")
        if lhs in needed and "sin(" not in rhs and "cos(" not in rhs:
            keep.append(ln)
            needed |= {t for t in rhs.split() if t[:2] in ("s_", "c_")}
    return keep[::-1]


def _hoist(d: Derivation, exprs: list[sp.Expr]) -> tuple[list[sp.Expr], list[sp.Expr], list[str]]:
    """Split expressions into parameter-only coefficients and what varies with the state.

    Each expression, trig-rewritten (:func:`_trig`), is a polynomial in the sin/cos
    symbols and the joint velocities whose coefficients involve only the parameters
    and g. Every distinct coefficient (up to sign) becomes a symbol ``k<i>``, computed
    once per leg instead of at every evaluation; the polynomials are then grouped by
    velocity products. Returns (rewritten expressions, the coefficients in ``k``
    order, the trig preamble).
    """
    exprs, trig = _trig(d, exprs)
    angles = sorted({s for e in exprs for s in e.free_symbols if s.name[:2] in ("s_", "c_")},
                    key=str)
    atoms = [*angles, *d.dq]
    coeffs: dict[sp.Expr, sp.Symbol] = {}

    def k(c: sp.Expr) -> sp.Expr:
        c = sp.expand(c)
        neg = c.could_extract_minus_sign()
        c = -c if neg else c
        if c not in coeffs:
            coeffs[c] = sp.Symbol(f"k{len(coeffs)}")
        return -coeffs[c] if neg else coeffs[c]

    products = [a * b for a, b in combinations_with_replacement(d.dq, 2)]
    out = []
    for e in exprs:
        terms = sp.Poly(sp.expand(e), *atoms).terms()
        e = sp.Add(*(k(c) * sp.Mul(*(a**m for a, m in zip(atoms, mon, strict=True)))
                     for mon, c in terms))
        out.append(sp.collect(sp.collect(sp.expand(e), products), list(d.dq)))
    return out, list(coeffs), trig


def _adjugate_solve(n: int, mat: str, rhs: str, out: str) -> list[str]:
    """Unrolled solve of the symmetric ``mat`` (names ``mat_j_k``, j <= k) by its adjugate.

    One division (by the determinant) where an LDL^T solve needs n in a chain: on a
    3 x 3 inertia matrix the divisions' latency, not the arithmetic, bound the stepper.
    """
    S = sp.Matrix(n, n, lambda j, k: sp.Symbol(f"{mat}_{min(j, k)}_{max(j, k)}"))
    A = S.adjugate()
    lines = [f"A{j}_{k} = {_code(sp.expand(A[j, k]))}" for j in range(n) for k in range(j, n)]

    def a(j: int, k: int) -> str:
        return f"A{min(j, k)}_{max(j, k)}"

    det = " + ".join(f"{mat}_0_{k} * {a(0, k)}" for k in range(n))
    lines.append(f"idet = 1.0 / ({det})")
    lines += [f"w{i} = (" + " + ".join(f"{a(i, k)} * {rhs}{k}" for k in range(n)) + ") * idet"
              for i in range(n)]
    lines += [f"{out}[{i}] = w{i}" for i in range(n)]
    return lines


def _function(name: str, args: str, doc: str, lines: list[str], inline: bool = False) -> str:
    """A numba kernel. error_model="numpy": a zero divisor gives inf/NaN (caught by the
    callers' finiteness checks) instead of a branch per division to raise
    ZeroDivisionError. ``inline``: inlined into the numba caller (the stepper's kernels:
    as calls they cost a reference count on ``k`` each and block scheduling across them)."""
    body = "\n".join("    " + ln for ln in lines)
    flags = ', inline="always"' if inline else ""
    return (f'@njit(cache=True, error_model="numpy"{flags})\ndef {name}({args}):\n'
            f'    """{doc}"""\n{body}\n')


def _given_trig(d: Derivation, name: str, args: str, doc: str, lines: list[str],
                returns: bool) -> list[str]:
    """The kernel ``name`` as two: ``<name>_trig``, its body given ``sc`` = (s_0, c_0,
    ..., s_n-1, c_n-1), the joints' sin and cos, in place of its libm calls (``q`` only
    where it needs the angles themselves), and ``name`` itself, which takes them from libm
    and calls it -- the same arithmetic, so the same bits. A caller that evaluates several
    kernels at one posture (the walking plant's stages, its contacts) takes the sin and
    cos once for all of them."""
    libm = [ln for ln in lines if " = sin(" in ln or " = cos(" in ln]
    body = [ln for ln in lines if ln not in libm]
    angles = {str(s) for s in d.q}
    unpack_q = [ln for ln in body if ln.split(" = ")[0] in angles]
    rest = [ln for ln in body if ln not in unpack_q]
    needs_q = any(a in re.findall(r"\w+", ln) for ln in rest for a in angles)
    sc = [f"s_{i}, c_{i}" for i in range(d.n)]
    trig_args = args.replace("q, ", "sc, q, " if needs_q else "sc, ", 1)
    head = ", ".join(sc) + " = sc"
    kernel = _function(f"{name}_trig", trig_args,
                       doc + "\n    Given sc = (sin q0, cos q0, ...) (the wrapper's libm calls).",
                       [head] + (unpack_q if needs_q else []) + rest)
    taken = {ln.split(" = ")[0]: ln.split(" = ")[1] for ln in libm}
    values = ", ".join(taken.get(v, "0.0").replace(f"({q})", f"(q[{i}])")
                       for i, q in enumerate(d.q) for v in (f"s_{i}", f"c_{i}"))
    call = f"{name}_trig(({values}), {trig_args.replace('sc, ', '', 1)})"
    wrapper = _function(name, args, doc, [("return " if returns else "") + call])
    return [kernel, wrapper]


def generate(d: Derivation) -> str:
    """Python source of every kernel for derivation ``d``."""
    n = d.n
    upper = [(j, k) for j in range(n) for k in range(j, n)]
    cdq = d.C * sp.Matrix(d.dq)
    funcs = []

    lines = _body(d, [d.M[j, k] for j, k in upper], [f"M_{j}_{k}" for j, k in upper], ["q"])
    lines += [f"out[{j}, {k}] = M_{j}_{k}" for j, k in upper]
    lines += [f"out[{k}, {j}] = M_{j}_{k}" for j, k in upper if j != k]
    funcs += _given_trig(d, "mass_matrix", "q, p, out", "M(q) (eq 17) into out (n, n).", lines,
                         False)

    lines = _body(d, list(d.C), [f"out[{i // n}, {i % n}]" for i in range(n * n)], ["q", "dq"])
    funcs.append(_function("coriolis_matrix", "q, dq, p, out",
                           "C(q, dq) in Christoffel form (eq 18) into out (n, n).", lines))

    lines = _body(d, list(cdq), [f"out[{i}]" for i in range(n)], ["q", "dq"])
    funcs += _given_trig(d, "coriolis_dq", "q, dq, p, out", "C(q, dq) dq into out (n,).", lines,
                         False)

    lines = _body(d, list(d.G), [f"out[{i}]" for i in range(n)], ["q"])
    funcs += _given_trig(d, "gravity", "q, p, g, out", "G(q) (eq 19) into out (n,).", lines,
                         False)
    lines = _body(d, list(d.Mdot), [f"out[{i // n}, {i % n}]" for i in range(n * n)], ["q", "dq"])
    funcs.append(_function("mass_matrix_dot", "q, dq, p, out", "dM/dt into out (n, n).", lines))

    lines = _body(d, [d.T], ["T"], ["q", "dq"]) + ["return T"]
    funcs.append(_function("kinetic_energy", "q, dq, p", "Kinetic energy T, J.", lines))

    lines = _body(d, [d.V], ["V"], ["q"]) + ["return V"]
    funcs.append(_function("potential_energy", "q, p, g",
                           "Potential energy V (zero at the hip height), J.", lines))

    h = cdq + d.G
    lines = _body(d, [d.M[j, k] for j, k in upper] + list(h),
                  [f"M_{j}_{k}" for j, k in upper] + [f"h{i}" for i in range(n)], ["q", "dq"])
    solve = [f"b{i} = tau{i} - h{i}" for i in range(n)] + _adjugate_solve(n, "M", "b", "out")
    unpack_state = [f"{s} = {a}[{i}]" for a, syms in (("q", d.q), ("dq", d.dq))
                    for i, s in enumerate(syms)] + [f"tau{i} = tau[{i}]" for i in range(n)]
    body = [ln for ln in lines if not any(ln.startswith(f"{s} = ") for s in (*d.q, *d.dq))]
    funcs.append(_function(
        "forward_dynamics", "q, dq, tau, p, g, out",
        "ddq = M^-1 (tau - C dq - G) (eq 20) into out (n,), by the adjugate of M.",
        unpack_state + body + solve))

    # The stepper's kernels: parameter-only coefficients once per leg (``coefficients``),
    # then M, C dq + G and G as polynomials in them (a third fewer operations).
    nm = len(upper)
    poly, kexprs, trig = _hoist(d, [d.M[j, k] for j, k in upper] + list(h) + list(d.G))
    used = set().union(*(e.free_symbols for e in kexprs))
    funcs.append(_function(
        "coefficients", "p, g",
        f"The {len(kexprs)} parameter-only coefficients k of the *_sc kernels,\n"
        "    from the parameter vector p and g, as a tuple (passed by value: no reference count).",
        _unpack(d, used, []) + _cse(kexprs, [f"k{i}" for i in range(len(kexprs))])
        + ["return (" + ", ".join(f"k{i}" for i in range(len(kexprs))) + ",)"]))
    trig_args = ", ".join(f"s_{i}, c_{i}" for i in range(n))

    def hoisted(exprs: list[sp.Expr], targets: list[str]) -> list[str]:
        used = set().union(*(e.free_symbols for e in exprs))
        ks = [f"k{i} = k[{i}]" for i in range(len(kexprs)) if sp.Symbol(f"k{i}") in used]
        return ks + _composites(trig, exprs) + _cse(exprs, targets)

    g_body = hoisted(poly[nm + n:], [f"G{i}" for i in range(n)])
    g_body.append("return (" + ", ".join(f"G{i}" for i in range(n)) + ",)")
    funcs.append(_function(
        "gravity_sc", f"{trig_args}, k",
        "G given s_i = sin(q_i), c_i = cos(q_i) and the leg's coefficients k, as a tuple.",
        g_body, inline=True))
    m_h = hoisted(poly[:nm + n], [f"M_{j}_{k}" for j, k in upper] + [f"h{i}" for i in range(n)])
    body = m_h + [ln for ln in solve if not ln.startswith("out[")]
    body.append("return (" + ", ".join(f"w{i}" for i in range(n)) + ",)")
    # the scalars come as three tuples (sin/cos pairs, rates, torques or accelerations):
    # unpacked in the kernel, as cheap as separate arguments once compiled
    dqs = ", ".join(map(str, d.dq))
    unpack = [f"{trig_args} = sc", f"{dqs} = dq"]
    funcs.append(_function(
        "forward_dynamics_sc", "sc, dq, tau, k",
        "forward_dynamics on scalars, given sc = (s_0, c_0, ...), s_i = sin(q_i), c_i = cos(q_i)\n"
        "    instead of q, the tuples dq and tau and the leg's coefficients k, returning the "
        "tuple\n"
        "    ddq: no arrays, and a stepper that knows sin/cos cheaply (angle addition from the\n"
        "    previous stage) skips libm.",
        unpack + [", ".join(f"tau{i}" for i in range(n)) + " = tau"] + body, inline=True))
    body = m_h + [f"t{i} = " + " + ".join(f"M_{min(i, j)}_{max(i, j)} * ddq{j}" for j in range(n))
                  + f" + h{i}" for i in range(n)]
    body.append("return (" + ", ".join(f"t{i}" for i in range(n)) + ",)")
    funcs.append(_function(
        "inverse_dynamics_sc", "sc, dq, ddq, k",
        "inverse_dynamics on scalars, given sc = (s_0, c_0, ...), s_i = sin(q_i),\n"
        "    c_i = cos(q_i), the tuples dq and ddq and the leg's coefficients k, returning the\n"
        "    tuple tau.",
        unpack + [", ".join(f"ddq{i}" for i in range(n)) + " = ddq"] + body))

    # the simulator's per-step diagnostics in one kernel; the verification signal is the
    # quadratic form of the evaluated matrices Mdot and C, never simplified symbolically
    pairs = [(i, j) for i in range(n) for j in range(n)]
    lines = _body(d, [d.M[j, k] for j, k in upper] + [d.Mdot[i, j] for i, j in pairs]
                  + [d.C[i, j] for i, j in pairs] + [d.V],
                  [f"M_{j}_{k}" for j, k in upper] + [f"Md_{i}_{j}" for i, j in pairs]
                  + [f"C_{i}_{j}" for i, j in pairs] + ["V"], ["q", "dq"])
    lines = [ln for ln in lines if not any(ln.startswith(f"{s} = ") for s in (*d.q, *d.dq))]
    quad = [f"dq{i} * M_{min(i, j)}_{max(i, j)} * dq{j}" for i, j in pairs]
    lines += ["T = 0.5 * (" + " + ".join(quad) + ")",
              "mdq = " + " + ".join(f"dq{i} * Md_{i}_{j} * dq{j}" for i, j in pairs),
              "ver = " + " + ".join(f"dq{i} * (Md_{i}_{j} - 2.0 * C_{i}_{j}) * dq{j}"
                                    for i, j in pairs),
              "return (T, V, ver, mdq)"]
    funcs.append(_function(
        "diagnostics", "q, dq, p, g",
        "(T, V, dq^T (Mdot - 2C) dq, dq^T Mdot dq): kinetic and potential energy, the\n"
        "    verification signal of eq 29 (zero for an exact model) and the size of what cancels\n"
        "    in it, from M, Mdot and C evaluated at (q, dq).",
        unpack_state[:2 * n] + lines))

    ddq = sp.symbols(f"ddq0:{n}")
    tau_id = d.M * sp.Matrix(ddq) + h
    lines = _body(d, list(tau_id), [f"out[{i}]" for i in range(n)], ["q", "dq"])
    lines = [f"{ddq[i]} = ddq[{i}]" for i in range(n)] + lines
    funcs.append(_function("inverse_dynamics", "q, dq, ddq, p, g, out",
                           "tau = M ddq + C dq + G (eq 16) into out (n,).", lines))

    reg = regressor(d)
    cols = len(reg.pi)
    lines = _body(d, list(reg.Y), [f"out[{i // cols}, {i % cols}]" for i in range(n * cols)],
                  ["q", "dq"])
    lines = [f"{reg.ddq[i]} = ddq[{i}]" for i in range(n) if reg.ddq[i] in reg.Y.free_symbols
             ] + lines
    funcs.append(_function(
        "regressor", "q, dq, ddq, p, g, out",
        f"Y (n, {cols}) into out, tau = Y pi: per link (m, m cx, m cy, I + m (cx^2 + cy^2)),\n"
        "    then the joints' armatures (exoleg.dynamics.derive.regressor); from p only the\n"
        "    links' lengths.", lines))

    funcs += _kinematics(d)
    values = ", ".join(f"sin(q[{i}]), cos(q[{i}])" for i in range(n))
    funcs.append(_function(
        "joint_trig", "q",
        "(sin q0, cos q0, ..., sin q_n-1, cos q_n-1): the ``sc`` of the *_trig kernels, one\n"
        "    libm call per joint and function for all of them.", [f"return ({values})"],
        inline=True))

    header = (
        '"""Generated by exoleg.dynamics.codegen from exoleg.dynamics.derive -- do not edit.\n\n'
        f"Planar chain of {n} links, D-H offsets {list(d.offsets)} rad, sympy {sp.__version__}.\n"
        'Regenerate with ``python -m exoleg.dynamics.codegen``.\n"""\n'
        "# ruff: noqa\n"
        "from math import cos, sin\n\n"
        "from numba import njit\n\n"

        f"N_JOINTS = {n}\n"
        f"N_PARAMS = {len(d.p)}  # per link LINK_PARAMS, then per joint JOINT_PARAMS\n"
        f"LINK_PARAMS = {LINK_PARAMS!r}\n"
        f"JOINT_PARAMS = {JOINT_PARAMS!r}\n"
        f"N_COEFFICIENTS = {len(kexprs)}\n"
        f"N_INERTIAL = {cols}  # the regressor's columns: per link BARYCENTRIC, the armatures\n"
        f"BARYCENTRIC = {BARYCENTRIC!r}\n"
        f"OFFSETS = {tuple(d.offsets)!r}\n\n\n"
    )
    return header + "\n\n".join(funcs)


def _kinematics(d: Derivation) -> list[str]:
    """The kinematics kernels, from the same derivation as the dynamics: the joints'
    points, a point of the last link with its velocity and Jacobian, and the terms of the
    links' mass height Y that a chain on a vertically free base needs."""
    n = d.n
    funcs = []
    qv, dqv = sp.Matrix(d.q), sp.Matrix(d.dq)
    pts = [e for j in d.joints for e in j]
    lines = _body(d, pts, [f"out[{i // 2}, {i % 2}]" for i in range(len(pts))], ["q"])
    funcs.append(_function(
        "joint_points", "q, p, out",
        f"The joints' points into out ({n + 1}, 2), m: the base joint (the origin), ..., the\n"
        "    last link's tip, in the base frame (x forward, y up).", lines))
    cs = [e for c in d.coms for e in c]
    lines = _body(d, cs, [f"out[{i // 2}, {i % 2}]" for i in range(len(cs))], ["q"])
    funcs.append(_function(
        "com_points", "q, p, out",
        f"The links' centres of mass into out ({n}, 2), m, in the base frame.", lines))
    P = d.point
    J = P.jacobian(qv)
    v = J * dqv
    lines = _body(d, [P[0], P[1], v[0], v[1], d.phi[-1]], ["x", "y", "vx", "vy", "phi"],
                  ["q", "dq"])
    funcs += _given_trig(
        d, "foot_point", "q, dq, p, px, py",
        "(x, y, vx, vy, phi): the point (px, py) of the last link's frame and its velocity\n"
        "    in the base frame, and the last link's absolute angle.",
        lines + ["return (x, y, vx, vy, phi)"], True)
    lines = _body(d, list(J), [f"out[{i // n}, {i % n}]" for i in range(2 * n)], ["q"])
    funcs += _given_trig(
        d, "foot_point_jacobian", "q, p, px, py, out",
        f"The Jacobian (2, {n}) of the point (px, py) of the last link's frame into out: a\n"
        "    force F on it acts on the joints as J^T F.", lines, False)
    grad = [sp.diff(d.Y, qi) for qi in d.q]
    hess = sum(sp.diff(d.Y, qi, qj) * dqi * dqj
               for qi, dqi in zip(d.q, d.dq, strict=True)
               for qj, dqj in zip(d.q, d.dq, strict=True))
    mass = sum(d.p[len(LINK_PARAMS) * i + LINK_PARAMS.index("m")] for i in range(n))
    lines = _body(d, [mass], ["mass"], []) + ["return mass"]
    funcs.append(_function("links_mass", "p", "The links' mass, kg (armature aside).", lines))
    lines = _body(d, [*grad, hess, mass], [*(f"dY{i}" for i in range(n)), "b", "mass"],
                  ["q", "dq"])
    funcs += _given_trig(
        d, "mass_height_terms", "q, dq, p",
        "Of Y(q) = sum m_i y_ci (the links' mass times their COM height): the gradient\n"
        f"    dY/dq ({n}), b = dq^T (d^2 Y / dq^2) dq, and the links' mass, as a tuple.",
        lines + ["return (" + ", ".join(f"dY{i}" for i in range(n)) + ", b, mass)"], True)
    lines = _body(d, [d.Y], ["Y"], ["q"])
    funcs.append(_function("mass_height", "q, p",
                           "Y(q) = sum m_i y_ci, kg m (zero at the base joint's height).",
                           lines + ["return Y"]))
    return funcs


def leg_offsets() -> tuple[float, ...]:
    """The leg's D-H offsets, from the paper's Table 3 data file."""
    from exoleg.params.paper import dh_offsets

    return dh_offsets()


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m exoleg.dynamics.codegen", description=__doc__)
    ap.add_argument("--check", action="store_true",
                    help="regenerate in memory and exit 1 if the shipped file differs")
    ap.add_argument("--output", type=Path, default=GENERATED)
    args = ap.parse_args(argv)
    src = generate(derive(leg_offsets()))
    if args.check:
        same = args.output.read_text() == src
        sys.stdout.write(f"{args.output}: {'up to date' if same else 'DIFFERS'}\n")
        return 0 if same else 1
    changed = not args.output.exists() or args.output.read_text() != src
    args.output.write_text(src)
    sys.stdout.write(f"wrote {args.output}\n")
    if changed:
        # numba's on-disk cache of a function that inlines a generated kernel (the stepper,
        # the control laws) is keyed on that function's own file, not on _generated.py:
        # after the kernels change, every cached entry of the package must go
        package = Path(__file__).resolve().parents[1]
        stale = [f for f in package.rglob("__pycache__/*") if f.suffix in (".nbi", ".nbc")]
        for f in stale:
            f.unlink()
        sys.stdout.write(f"removed {len(stale)} numba cache files of the old kernels\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
