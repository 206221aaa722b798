"""The particles' polar components turned into a node's, for nodes whose basis turns
about the axis (rings, cylindrical shells, the polar grid).

Each particle (and each of its branch segments) carries its quantities in the polar
basis at its own centre. A node's field is the field's components in the node's basis
at each of its points, turned from the particle's by the angle delta between the two
azimuths: e_r' = c e_r + s e_phi, e_phi' = -s e_r + c e_phi (c = cos delta,
s = sin delta), e_z' = e_z. The kernel weight w times a product of c and s averages to
one of five moments of the pair (:data:`MOMENTS`): 1 -> W0, c -> W1, s -> W2,
c^2 -> (W0 + W3) / 2, s^2 -> (W0 - W3) / 2, c s -> W4 / 2, with W0 = <w>,
W1 + i W2 = <w exp(i delta)>, W3 + i W4 = <w exp(2 i delta)>. A scalar takes W0, a
vector v'_i = sum_a R_ai v_a, a tensor T'_ij = sum_ab R_ai R_bj T_ab, an axial vector
in 3D as a vector (a proper rotation), in 2D (omega_z) as a scalar.

:func:`terms` lists, for a layout's blocks, the (out channel, in channel, moment,
coefficient) of these sums; :func:`granavg.engine.smoothing._kernels.mixed` applies them.
"""

from __future__ import annotations

import numpy as np
from granavg.engine.channels import BLOCK, Layout

#: Weights of a pair where the basis turns: W0 ... W4 (the compiled loops' arrays of 5).
MOMENTS = 5

_C, _S = "c", "s"
#: A product of c and s -> its moments.
_AVERAGE = {"": ((0, 1.0),), "c": ((1, 1.0),), "s": ((2, 1.0),),
            "cc": ((0, 0.5), (3, 0.5)), "ss": ((0, 0.5), (3, -0.5)), "cs": ((4, 0.5),)}


def _turn(axes):
    """R[a][i]: particle axis a -> node axis i, as (sign, monomial)."""
    R = {a: {} for a in axes}
    R["r"]["r"], R["phi"]["r"] = (1.0, _C), (1.0, _S)
    R["r"]["phi"], R["phi"]["phi"] = (-1.0, _S), (1.0, _C)
    if "z" in axes:
        R["z"]["z"] = (1.0, "")
    return R


def _product(*factors):
    sign, word = 1.0, ""
    for f, m in factors:
        sign *= f
        word += m
    return sign, "".join(sorted(word))


def block_terms(shape: str, axes) -> list:
    """(out component, in component, moment, coefficient) of one block's components."""
    R = _turn(axes)
    D = len(axes)
    out = []
    if shape == "couple":                   # a vector in 2D (about z), a tensor in 3D
        shape = "vector" if D == 2 else "tensor"

    def add(o, i, sign, word):
        for m, f in _AVERAGE[word]:
            out.append((o, i, m, sign * f))

    if shape == "scalar" or (shape == "axial" and D == 2):
        add(0, 0, 1.0, "")
    elif shape in ("vector", "axial"):
        for o, i in enumerate(axes):
            for n, a in enumerate(axes):
                if i in R[a]:
                    add(o, n, *R[a][i])
    elif shape == "tensor":
        for o1, i in enumerate(axes):
            for o2, j in enumerate(axes):
                for n1, a in enumerate(axes):
                    for n2, b in enumerate(axes):
                        if i in R[a] and j in R[b]:
                            add(o1 * D + o2, n1 * D + n2, *_product(R[a][i], R[b][j]))
    else:
        raise ValueError(f"no rotation for a {shape} block")
    return out


def terms(layout: Layout, blocks):
    """The terms of ``blocks`` (those the layout holds) as arrays (out, in, moment,
    coefficient) of channel columns."""
    rows = []
    for b in blocks:
        if b not in layout.blocks:
            continue
        first = layout.first(b)
        for o, i, m, f in block_terms(BLOCK[b].shape, layout.axes):
            rows.append((first + o, first + i, m, f))
    if not rows:
        return (np.zeros(0, np.int64),) * 3 + (np.zeros(0),)
    o, i, m, f = zip(*rows)
    return np.array(o), np.array(i), np.array(m), np.array(f)
