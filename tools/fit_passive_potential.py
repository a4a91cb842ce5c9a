"""Refit Riener & Edrich's passive moments as a conservative field
(data/child/passive.toml's ``[[term]]`` tables from its ``[[printed]]`` ones).

Riener & Edrich print each joint's moment as a sum of exponentials in all three joint
angles, each term on one joint: the field is not the gradient of any energy
(dM_hip/dphi_knee differs from dM_knee/dphi_hip), so the passive moments add or take
energy around a loop. exoleg's term k is instead one muscle group's passive force
exp(a_k + b_k . phi) acting through all the joints its exponent depends on, with moment
arms proportional to b_k: M_i = sign_k (b_k,i / b_k,own) exp(a_k + b_k . phi), the
gradient of sign_k exp(a_k + b_k . phi) / b_k,own. On its own joint the term is Riener's
form; on the joints it couples to it is the same muscle's moment there.

The terms' a and b are fitted (scipy least squares) to the printed equations' three
moments (constants aside: they are kept) on a 9 x 11 x 12 grid of the checked range,
weighted 1 where walking goes (ankle -20-20 deg, knee 0-70, hip -20-50) and 0.3 beyond;
each b keeps the printed signs and zero pattern, its own coefficient within half to
twice the printed one and each coupling's moment arm at most twice the own joint's (a
free fit made the knee extensors independent of the knee and their tiny own
coefficient a lever of thousands on the ankle). Prints the fit's residuals; with
--write replaces the ``[[term]]`` tables. Needs scipy (a development tool).

    python tools/fit_passive_potential.py [--write]
"""

from __future__ import annotations

import re
import sys
import tomllib
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

PATH = Path(__file__).resolve().parents[1] / "src/exoleg/data/child/passive.toml"
JOINT = {"hip": 0, "knee": 1, "ankle": 2}
OWN = {0: 2, 1: 1, 2: 0}  # a joint's coordinate in phi = (A, K, H)


def grid() -> tuple[np.ndarray, np.ndarray]:
    A, K, H = np.linspace(-30, 30, 9), np.linspace(0, 100, 11), np.linspace(-20, 90, 12)
    ph = np.stack(np.meshgrid(A, K, H, indexing="ij"), -1).reshape(-1, 3)
    gait = (np.abs(ph[:, 0]) <= 20) & (ph[:, 1] <= 70) & (ph[:, 2] <= 50)
    return ph, np.where(gait, 1.0, 0.3)


def printed(terms: list[dict], ph: np.ndarray) -> np.ndarray:
    m = np.zeros((len(ph), 3))
    for t in terms:
        m[:, JOINT[t["joint"]]] += t["sign"] * np.exp(t["a"] + ph @ np.array(t["b"]))
    return m


def conservative(terms: list[dict], ab: list[tuple[float, np.ndarray]],
                 ph: np.ndarray) -> np.ndarray:
    m = np.zeros((len(ph), 3))
    for t, (a, b) in zip(terms, ab, strict=True):
        e = np.exp(a + ph @ b)
        own = b[OWN[JOINT[t["joint"]]]]
        for j in range(3):
            m[:, j] += t["sign"] * b[OWN[j]] / own * e
    return m


def main() -> None:
    d = tomllib.loads(PATH.read_text())
    terms = d["printed"]
    ph, w = grid()
    want = printed(terms, ph)
    scale = np.sqrt(np.mean(want ** 2, axis=0))
    mask = [np.array(t["b"]) != 0 for t in terms]

    def unpack(x: np.ndarray) -> list[tuple[float, np.ndarray]]:
        """(a, b) per term from x: per term a, its own coefficient, then each coupling as
        its ratio to the own one (the ratio of the muscle's moment arms)."""
        out, i = [], 0
        for t, m in zip(terms, mask, strict=True):
            own = OWN[JOINT[t["joint"]]]
            b = np.zeros(3)
            b[own] = x[i + 1]
            cpl = [c for c in range(3) if m[c] and c != own]
            for n, c in enumerate(cpl):
                b[c] = x[i + 2 + n] * x[i + 1]
            out.append((float(x[i]), b))
            i += 2 + len(cpl)
        return out

    x0, lo, hi = [], [], []
    for t, m in zip(terms, mask, strict=True):
        own = OWN[JOINT[t["joint"]]]
        pb = np.array(t["b"])
        x0 += [t["a"], pb[own]]
        lo.append(-30.0)
        hi.append(30.0)
        # the own coefficient within half to twice the printed one
        lo.append(min(0.5 * pb[own], 2.0 * pb[own]))
        hi.append(max(0.5 * pb[own], 2.0 * pb[own]))
        for c in range(3):
            if m[c] and c != own:
                ratio = pb[c] / pb[own]
                x0.append(ratio)
                # a moment arm at most twice the own joint's, the printed sign kept
                lo.append(0.0 if ratio > 0 else -2.0)
                hi.append(2.0 if ratio > 0 else 0.0)
    x0 = list(np.clip(x0, np.array(lo) + 1e-9, np.array(hi) - 1e-9))

    def resid(x: np.ndarray) -> np.ndarray:
        return (w[:, None] * (conservative(terms, unpack(x), ph) - want) / scale).ravel()

    r = least_squares(resid, np.array(x0), bounds=(lo, hi), x_scale="jac", max_nfev=20000)
    ab = unpack(r.x)
    got = conservative(terms, ab, ph)
    walking = w == 1.0
    for name, sel in (("where walking goes", walking),
                      ("the whole checked range", np.ones_like(walking))):
        e = got[sel] - want[sel]
        print(f"{name}: RMS {np.round(np.sqrt(np.mean(e ** 2, axis=0)), 2)} N m, max "
              f"{np.round(np.abs(e).max(axis=0), 2)} N m (hip, knee, ankle; adults)")
    lines = []
    for t, (a, b) in zip(terms, ab, strict=True):
        lines += ["[[term]]", f'joint = "{t["joint"]}"', f'group = "{t["group"]}"',
                  f"sign = {t['sign']}", f"a = {a:.6f}",
                  f"b = [{b[0]:.6f}, {b[1]:.6f}, {b[2]:.6f}]", ""]
    text = "\n".join(lines)
    print(text)
    if "--write" in sys.argv:
        src = PATH.read_text()
        head = re.split(r"^\[\[term\]\]", src, maxsplit=1, flags=re.M)[0]
        PATH.write_text(head + text)


if __name__ == "__main__":
    main()
