"""The step-length controller's inference, compiled: ``aim_rows`` is what ``StepLengthController.leg_angles``
returns, and the planning core (planners/core) aims every batch of candidate footholds and perturbed robots with it.

It computes the network as numpy does (``x @ w + b``, ``np.tanh``): numpy's BLAS routine for the products (numba's
``np.dot`` calls the same one) and numpy's own inner loop for float64 tanh (its vectorized tanh rounds otherwise than
the C library's), found on the ufunc object (``numpy_loop``) and checked against ``np.tanh`` when this module loads,
so no call goes back into Python and a batch of one row costs little more than its arithmetic
(tests/test_core.py checks the angles against the network in numpy, to the bit). The polish is
``drakeslip.leg_aim.polish_one``."""
from __future__ import annotations

import ctypes
from collections import namedtuple

import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from drakeslip.compiled import compiled
from drakeslip.leg_aim import polish_one

# numpy's inner loop: void loop(char **args, npy_intp const *dimensions, npy_intp const *steps, void *data)
_LOOP = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p)


class _UFuncHead(ctypes.Structure):
    """The leading fields of numpy's ``PyUFuncObject`` (numpy/ufuncobject.h, numpy's public C API; ``numpy_loop``
    checks what it reads)."""

    _fields_ = [("ob_refcnt", ctypes.c_ssize_t), ("ob_type", ctypes.c_void_p), ("nin", ctypes.c_int),
                ("nout", ctypes.c_int), ("nargs", ctypes.c_int), ("identity", ctypes.c_int),
                ("functions", ctypes.POINTER(ctypes.c_void_p)), ("data", ctypes.POINTER(ctypes.c_void_p)),
                ("ntypes", ctypes.c_int), ("reserved1", ctypes.c_int), ("name", ctypes.c_char_p)]


def numpy_loop(ufunc: np.ufunc, signature: str = "d->d") -> tuple:
    """(address of numpy's inner loop for a one-input ``ufunc`` on ``signature``, its data pointer), the loop numpy
    itself runs on a float64 array, checked to give ``ufunc``'s values to the bit on probe values; RuntimeError if
    this numpy's ufunc objects are not laid out as expected."""
    head = _UFuncHead.from_address(id(ufunc))
    if head.name != ufunc.__name__.encode() or (head.nin, head.nout) != (1, 1) or head.ntypes != len(ufunc.types):
        raise RuntimeError(f"numpy {np.__version__}: the ufunc object of {ufunc.__name__} is not laid out as "
                           "numpy/ufuncobject.h says")
    index = ufunc.types.index(signature)
    loop, data = head.functions[index], head.data[index] or 0
    probe = np.concatenate((np.linspace(-25.0, 25.0, 4001), [0.0, -0.0, 1e-300, -1e-300, 710.0, -710.0]))
    out = np.empty_like(probe)
    pointers = (ctypes.c_void_p * 2)(probe.ctypes.data, out.ctypes.data)
    dims, steps = (ctypes.c_ssize_t * 1)(probe.size), (ctypes.c_ssize_t * 2)(8, 8)
    _LOOP(loop)(ctypes.addressof(pointers), ctypes.addressof(dims), ctypes.addressof(steps), data)
    if not np.array_equal(out, ufunc(probe)):
        raise RuntimeError(f"numpy {np.__version__}: the inner loop found for {ufunc.__name__} ({signature}) does not "
                           "give its values")
    return loop, data


TANH_LOOP = numpy_loop(np.tanh)


@intrinsic
def _call_loop(typingctx, loop, pointers, dims, steps, data):
    """Call the inner loop at address ``loop`` with the addresses of its argument arrays."""
    def codegen(context, builder, signature, args):
        byte_pointer = ir.IntType(8).as_pointer()
        function = ir.FunctionType(ir.VoidType(), [byte_pointer] * 4)
        address = builder.inttoptr(args[0], function.as_pointer())
        builder.call(address, [builder.inttoptr(a, byte_pointer) for a in args[1:]])
        return context.get_dummy_value()

    return types.void(loop, pointers, dims, steps, data), codegen


class ControllerArrays(namedtuple("ControllerArrays", [
        "w_in", "b_in", "w_hidden", "b_hidden", "w_head", "b_head", "mean", "std", "scale", "max_angle", "leg_length",
        "gravity", "refine", "tanh_loop", "tanh_data"])):
    """A controller's network as arrays for compiled code: input layer ``w_in`` (3, H) and ``b_in`` (H,), hidden
    layers ``w_hidden`` (L-1, H, H) and ``b_hidden`` (L-1, H), head ``w_head`` (H,) and ``b_head``; the feature
    statistics ``mean``, ``std`` and the hopper's ``scale`` (ones for the trained hopper), ``max_angle``, and the
    aimed hopper's ``leg_length``, ``gravity``; ``refine``: polish with Newton steps; numpy's tanh loop and its data
    pointer (``TANH_LOOP``), which ``controller_arrays`` fills in."""
    __slots__ = ()


def controller_arrays(*fields) -> ControllerArrays:
    """A ``ControllerArrays`` of the network's fields (w_in .. refine) and numpy's tanh loop."""
    return ControllerArrays(*fields, *TANH_LOOP)


@compiled()
def _tanh_rows(x, loop, data):
    """numpy's tanh of a C-contiguous array, by numpy's inner ``loop`` (``TANH_LOOP``)."""
    y = np.empty_like(x)
    pointers = np.empty(2, np.uintp)
    pointers[0], pointers[1] = x.ctypes.data, y.ctypes.data
    dims, steps = np.full(1, x.size, np.intp), np.full(2, 8, np.intp)
    _call_loop(loop, pointers.ctypes.data, dims.ctypes.data, steps.ctypes.data, data)
    return y


@compiled()
def _plus_row(m, row):
    """``m + row`` (numpy's broadcast of a row over a matrix's rows), in place: the same sums, without the broadcast's
    shape checks to compile."""
    for i in range(m.shape[0]):
        for j in range(m.shape[1]):
            m[i, j] += row[j]
    return m


@compiled()
def aim_rows(apexes, footholds, grounds, net):
    """The leg angle for each row: apex (x, z, xdot), desired foothold and the ground's height there (``net``:
    ``ControllerArrays``); the network's features (speed, drop, offset) are scaled to the trained hopper's
    units and normalized, the angle clipped to +-max_angle and, with ``refine``, polished."""
    mean, std, scale, max_angle, loop, data = net.mean, net.std, net.scale, net.max_angle, net.tanh_loop, net.tanh_data
    n = footholds.shape[0]
    feats, x = np.empty((n, 3)), np.empty((n, 3))
    for i in range(n):
        feats[i, 0] = apexes[i, 2]
        feats[i, 1] = apexes[i, 1] - grounds[i]
        feats[i, 2] = footholds[i] - apexes[i, 0]
        for j in range(3):   # element by element, as numpy's broadcast computes each: (feats / scale - mean) / std
            x[i, j] = (feats[i, j] / scale[j] - mean[j]) / std[j]
    x = _tanh_rows(_plus_row(np.dot(x, net.w_in), net.b_in), loop, data)
    for layer in range(net.w_hidden.shape[0]):
        x = _tanh_rows(_plus_row(np.dot(x, net.w_hidden[layer]), net.b_hidden[layer]), loop, data)
    theta = np.empty(n)
    head = np.dot(x, net.w_head.reshape(-1, 1))
    for i in range(n):
        theta[i] = min(max((head[i, 0] + net.b_head) * max_angle, -max_angle), max_angle)
        if net.refine:
            theta[i] = polish_one(feats[i, 0], feats[i, 1], feats[i, 2], theta[i], net.leg_length, net.gravity,
                                  max_angle)
    return theta
