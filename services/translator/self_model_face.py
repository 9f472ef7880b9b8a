"""The self-model's predicted face and its Jacobian, computed fast in plain numpy.

A :class:`PolyRidge` forward model of degree ``d`` over ``S`` servos is a polynomial in
``v = [u, 1]`` (``K = S + 1`` entries), so it can be written as a symmetric tensor ``W`` of shape
(F, K, …, K) with ``d`` axes of size K. Each term's coefficient is shared equally among the
orders of its factors, and the intercept sits at [K-1, …, K-1]. Then

    face = W·v·…·v  (d contractions),   ∂face/∂u_s = d · (W·v·…·v)[:, s]  (d − 1 contractions)

because a symmetric tensor's gradient is ``d`` times its contraction with one ``v`` fewer.
:class:`PolyFace` keeps ``d · W`` reshaped to 2-D, (F·K^(d-1), K). One evaluation is then d − 1
matrix-vector products giving ``m = d·W·v^(d-1)`` (F, K): the Jacobian is ``m[:, :S]`` and the
face is ``m @ v / d``. For simhead16 (degree 2, 16 servos, 53 features) that is one (901, 17)
matrix times a vector. The terms' way needs 152 terms' products, their derivatives and a
(53, 152) by (152, 16) product. The sums come in another order, so the results differ from the
terms' way only by rounding (relative 1e-16).

Where the tensor would hold more than :data:`MAX_CELLS` numbers (degree 3 or 4 with many
servos), the terms' way is used, without Python loops: each term's product of its other factors
is gathered by precomputed indices and summed into its servo's column with one ``bincount``.
That gives exactly what the factor-by-factor loop gives.
"""

from __future__ import annotations

import copy
import itertools

import numpy as np

from facesynth.runtime.profiles.learned import PolyRidge, unpack
from facesynth.runtime.profiles.learned_predict import poly_factors

#: The largest symmetric tensor kept (numbers; 16 MB). Beyond it, the terms' way is used.
MAX_CELLS = 1 << 21


class PolyFace:
    """A :class:`PolyRidge` forward model's face and Jacobian at commands ``v = [u, 1]``."""

    def __init__(self, forward: PolyRidge, max_cells: int = MAX_CELLS) -> None:
        """``max_cells``: the largest tensor (numbers) kept, else the terms' way."""
        self.coef = unpack(forward.coef)  # (features, terms)
        self.intercept = unpack(forward.intercept)
        self.n_servos = unpack(forward.powers).shape[1]
        #: Each term as the entries of ``v`` it multiplies (index n_servos: the constant 1).
        self.factors = poly_factors(forward)
        self.degree = self.factors.shape[1]
        self.max_cells = max_cells
        self._build()

    def _build(self) -> None:
        """The tensor, or the terms' way's indices where it would be too large."""
        width = self.n_servos + 1
        self.tensor: np.ndarray | None = None
        if len(self.coef) * width**self.degree <= self.max_cells:
            self.tensor = self._symmetric(width)
        else:
            self._prepare_terms(width)

    def reordered(self, order: np.ndarray) -> PolyFace:
        """The same model with its servos in ``order`` (servo i of the copy is servo
        ``order[i]`` of this one; a permutation), for a plan that moves the first few."""
        place = np.empty(self.n_servos + 1, dtype=np.intp)
        place[np.append(order, self.n_servos)] = np.arange(self.n_servos + 1)
        other = copy.copy(self)
        other.factors = place[self.factors]
        other._build()
        return other

    def _symmetric(self, width: int) -> np.ndarray:
        """``d · W`` as (F·K^(d-1), K): each term's coefficient over its factors' orders."""
        d = self.degree
        orders = list(itertools.permutations(range(d)))
        cells = np.zeros((width**d, len(self.coef)))
        share = self.coef.T * (d / len(orders))  # (terms, features)
        for order in orders:
            at = np.ravel_multi_index(tuple(self.factors[:, order].T), (width,) * d)
            np.add.at(cells, at, share)
        cells[-1] += d * self.intercept  # [K-1, ..., K-1]: the constant's cell
        return np.ascontiguousarray(cells.T).reshape(-1, width)

    def _prepare_terms(self, width: int) -> None:
        """The terms' way's indices: each factor's other factors, and where its product goes."""
        d = self.degree
        self.others = np.array(
            [[c for c in range(d) if c != column] for column in range(d)], dtype=np.intp
        )
        rows = np.arange(len(self.factors))[:, None]
        self.columns = (rows * width + self.factors).ravel()  # term t, factor c → (t, index)
        self.width = width

    def at(self, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The predicted standardized face (F,) and its Jacobian (F, S) at ``v = [u, 1]``
        (a view into the model's own arrays for degree 1: not to be written to)."""
        if self.tensor is None:
            return self._terms(v)
        m = self.tensor
        for _ in range(self.degree - 1):
            m = np.dot(m, v).reshape(-1, len(v))
        face: np.ndarray = np.dot(m, v) / self.degree
        return face, m[:, : self.n_servos]

    def _terms(self, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Term by term (bit-identical to the factor-by-factor loop), for large tensors."""
        values = v[self.factors]  # (T, degree)
        terms = values.prod(axis=1)
        others = values[:, self.others].prod(axis=2)  # (T, degree): the other factors
        size = len(self.factors) * self.width
        d_terms = np.bincount(self.columns, others.ravel(), size).reshape(-1, self.width)
        face: np.ndarray = self.coef @ terms + self.intercept
        jacobian: np.ndarray = self.coef @ d_terms[:, : self.n_servos]
        return face, jacobian
