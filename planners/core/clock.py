"""A monotonic clock for compiled code, and the per-call time accounting of a planning call.

``now()`` reads CLOCK_MONOTONIC, the clock behind ``time.perf_counter`` on Linux, so a compiled search compares
it with a problem's deadline directly; a call costs tens of nanoseconds, so the core times every controller, model
and step-map call without changing what it measures. In Python (the search loop run as Python, ``best_first``) it is
``time.perf_counter`` itself. A core adds the seconds it spent in each part to a slots array (STEP_MAP, CONTROLLER,
MODEL), which ``planners.base.Timing.add`` reads."""
from __future__ import annotations

import time

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic, overload

# slots of a core's time array: seconds in each part of a planning call
STEP_MAP, CONTROLLER, MODEL, N_SLOTS = 0, 1, 2, 3
CLOCK_MONOTONIC = 1


@intrinsic
def _monotonic_ns(typingctx):
    def codegen(context, builder, signature, args):
        i64, i32 = ir.IntType(64), ir.IntType(32)
        timespec = ir.LiteralStructType([i64, i64])
        prototype = ir.FunctionType(i32, [i32, timespec.as_pointer()])
        clock_gettime = cgutils.get_or_insert_function(builder.module, prototype,
                                                       "clock_gettime")
        ts = cgutils.alloca_once(builder, timespec)
        builder.call(clock_gettime, [ir.Constant(i32, CLOCK_MONOTONIC), ts])
        seconds = builder.load(cgutils.gep_inbounds(builder, ts, 0, 0))
        nanoseconds = builder.load(cgutils.gep_inbounds(builder, ts, 0, 1))
        return builder.add(builder.mul(seconds, ir.Constant(i64, 1_000_000_000)), nanoseconds)

    return types.int64(), codegen


def now() -> float:
    """Seconds on the monotonic clock (``time.perf_counter()``'s); compiled code reads the clock itself."""
    return time.perf_counter()


@overload(now)
def _now():
    return lambda: _monotonic_ns() * 1e-9
