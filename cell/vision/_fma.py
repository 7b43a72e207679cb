"""Fused multiply-add for the compiled kernels: ``a * b + c`` rounded once.

Some kernels reproduce, bit for bit, arithmetic that numpy or OpenCV do with a fused
multiply-add (numpy's matrix product on this machine, ``cv2.transform``); numba has no
``fma``, so :func:`fma` calls LLVM's ``llvm.fma`` intrinsic for float32 or float64.
"""

from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

__all__: list[str] = []  # private to cell.vision


@intrinsic
def fma(typingctx, a, b, c):  # pragma: no cover (compiled)
    """a * b + c, rounded once, in the arguments' type (all float32 or all float64)."""
    if not (a == b == c and a in (types.float32, types.float64)):
        return None  # (numba then reports no matching signature)
    sig = a(a, a, a)

    def codegen(context, builder, signature, args):
        f = ir.FloatType() if a == types.float32 else ir.DoubleType()
        fn = builder.module.declare_intrinsic("llvm.fma", [f], ir.FunctionType(f, [f, f, f]))
        return builder.call(fn, args)

    return sig, codegen
