"""The SLIP equations on any number type, for trajectory optimization: one definition of the SLIP.

The functions in ``drakeslip.dynamics`` are numba-compiled scalar functions; ``generic`` takes the very Python
source numba compiled (``py_func``) and binds its ``math`` to functions that also accept ``Dual`` (a small
vectorized forward-mode type), numpy arrays, ``AutoDiffXd`` and symbolic ``Expression``. ``dual_constraint``
turns a function of ``Dual`` into a Drake constraint callback, so the collocation defects of a whole stance and
their Jacobian come from one vectorized ``Dual`` pass.
"""
from __future__ import annotations

import functools
import math
import types

import numpy as np


class Dual:
    """Forward-mode derivatives over numpy arrays: ``val`` of any shape, ``der`` of shape val.shape + (n,) (the
    derivatives with respect to n variables). Enough arithmetic for the SLIP equations, so one vectorized pass
    gives a hop's constraint values and Jacobian (far cheaper than Drake's scalar AutoDiffXd or symbolic
    evaluation from Python)."""

    __array_ufunc__ = None  # numpy arrays and scalars defer to Dual's reflected operators

    def __init__(self, val, der):
        self.val = np.asarray(val, dtype=np.float64)
        der = np.asarray(der, dtype=np.float64)
        if der.shape[:-1] != self.val.shape:  # e.g. a scalar Dual plus an array of constants
            der = np.broadcast_to(der, self.val.shape + der.shape[-1:])
        self.der = der

    @classmethod
    def variables(cls, values) -> "Dual":
        values = np.asarray(values, dtype=np.float64).reshape(-1)
        return cls(values, np.eye(values.size))

    def _d(self, other):
        return (other.val, other.der) if isinstance(other, Dual) else (np.asarray(other, dtype=np.float64), 0.0)

    def __getitem__(self, i):
        return Dual(self.val[i], self.der[i])

    def __len__(self):
        return len(self.val)

    def __iter__(self):
        return (self[i] for i in range(len(self)))

    def __neg__(self):
        return Dual(-self.val, -self.der)

    def __add__(self, other):
        v, d = self._d(other)
        return Dual(self.val + v, self.der + d)

    __radd__ = __add__

    def __sub__(self, other):
        v, d = self._d(other)
        return Dual(self.val - v, self.der - d)

    def __rsub__(self, other):
        return Dual(np.asarray(other, dtype=np.float64) - self.val, -self.der)

    def __mul__(self, other):
        v, d = self._d(other)
        der = self.der * np.asarray(v)[..., None]
        if isinstance(other, Dual):
            der = der + d * self.val[..., None]
        return Dual(self.val * v, der)

    __rmul__ = __mul__

    def __truediv__(self, other):
        v, d = self._d(other)
        der = self.der / np.asarray(v)[..., None]
        if isinstance(other, Dual):
            der = der - d * (self.val / (v * v))[..., None]
        return Dual(self.val / v, der)

    def __rtruediv__(self, other):
        c = np.asarray(other, dtype=np.float64)
        return Dual(c / self.val, -self.der * (c / (self.val * self.val))[..., None])

    def __rmatmul__(self, matrix):
        matrix = np.asarray(matrix, dtype=np.float64)
        return Dual(matrix @ self.val, matrix @ self.der)

    def __pow__(self, e):
        if isinstance(e, Dual):
            raise TypeError("Dual ** Dual is not supported")
        return Dual(self.val ** e, self.der * (e * self.val ** (e - 1))[..., None])

    def sqrt(self):
        r = np.sqrt(self.val)
        return Dual(r, self.der * (0.5 / r)[..., None])

    def sin(self):
        return Dual(np.sin(self.val), self.der * np.cos(self.val)[..., None])

    def cos(self):
        return Dual(np.cos(self.val), -self.der * np.sin(self.val)[..., None])

    @staticmethod
    def concat(parts) -> "Dual":
        """Concatenate Duals (and constants) into one 1-D Dual."""
        n = next(p.der.shape[-1] for p in parts if isinstance(p, Dual))
        vals, ders = [], []
        for p in parts:
            v = np.atleast_1d(p.val if isinstance(p, Dual) else np.asarray(p, dtype=np.float64))
            vals.append(v.reshape(-1))
            d = np.broadcast_to(p.der, v.shape + (n,)) if isinstance(p, Dual) else np.zeros(v.shape + (n,))
            ders.append(d.reshape(v.size, n))
        return Dual(np.concatenate(vals), np.concatenate(ders))


def _dispatch(name: str):
    import pydrake.math as pm

    drake_fn, numpy_fn = getattr(pm, name), getattr(np, name)

    def fn(x):
        if isinstance(x, Dual):
            return getattr(x, name)()
        if isinstance(x, np.ndarray) and x.dtype != object:
            return numpy_fn(x)
        return drake_fn(x)

    fn.__name__ = name
    return fn


@functools.cache
def _generic_math():
    return types.SimpleNamespace(sqrt=_dispatch("sqrt"), sin=_dispatch("sin"), cos=_dispatch("cos"),
                                 floor=math.floor, inf=math.inf, pi=math.pi)


@functools.cache
def generic(fn):
    """The plain-Python source of a ``drakeslip.dynamics`` function (the very code numba compiled, its
    ``py_func``) with ``math`` bound to functions that also take ``Dual``, numpy arrays, ``AutoDiffXd`` and
    ``symbolic.Expression``. Compiled functions it calls are made generic too."""
    py = getattr(fn, "py_func", fn)
    scope = dict(py.__globals__)
    scope["math"] = _generic_math()
    for name in py.__code__.co_names:
        value = scope.get(name)
        if hasattr(value, "py_func"):
            scope[name] = generic(value)
    return types.FunctionType(py.__code__, scope, py.__name__, py.__defaults__, py.__closure__)


def dual_constraint(fun, n_out: int):
    """A Drake constraint callback from ``fun(Dual over the bound variables) -> Dual of n_out values``: the
    solver's AutoDiffXd input is turned into one Dual, and the result's Jacobian chained back."""
    from pydrake.autodiffutils import ExtractGradient, ExtractValue, InitializeAutoDiff

    def evaluate(v):
        with np.errstate(divide="ignore", invalid="ignore"):  # a trial point may put the body on its foot
            return _evaluate(v)

    def _evaluate(v):
        if v.dtype == object:
            x = ExtractValue(v).reshape(-1)
            out = fun(Dual.variables(x))
            grad = ExtractGradient(v)
            if grad.shape == (x.size, x.size) and np.array_equal(grad, np.eye(x.size)):
                jac = out.der  # the solvers pass the bound variables themselves
            else:  # einsum, not BLAS: a threaded BLAS call costs ms on a busy machine
                jac = np.einsum("ij,jk->ik", out.der, grad)
            return InitializeAutoDiff(out.val.reshape(-1, 1), jac)
        v = np.asarray(v, dtype=np.float64).reshape(-1)
        return fun(Dual(v, np.zeros((v.size, 0)))).val  # values only: derivatives over no variables

    return evaluate
