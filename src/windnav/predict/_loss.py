"""The decoder's training loss and its gradient in one compiled pass (private).

:func:`windnav.predict.train._loss` writes the loss as some thirty whole-batch torch operations,
each a pass over the ``(B, 2, H^2)`` field and each with its own backward: 5.0 ms forward and
3.8 ms backward of a 22.9 ms training step of 256 samples on an Intel Xeon (2026-12-03). Here
the same sums (vector term, speed term, ``1 - cos`` direction term) and their analytic gradient
with respect to the prediction come out of one loop over the cells, in float32 as torch's;
the gradient is kept for the backward pass. The values agree with the torch formula to float32
rounding (tests/test_predict_train.py), not bit for bit.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from windnav._jit import njit

SPEED_REF = 10.0  # m/s, the reference speed of the loss weight (U / SPEED_REF)^p
DIRECTION_FADE = 0.1  # U: the direction term fades out below this speed (train.direction_fade)


@njit(cache=True, nogil=True)
def free_count(free):  # pragma: no cover - numba
    """The number of free cells of ``free`` (B, M)."""
    n_free = 0
    for b in range(free.shape[0]):
        for m in range(free.shape[1]):
            n_free += free[b, m] > 0
    return n_free


@njit(cache=True, nogil=True, error_model="numpy")
def loss_rows(pred, labels, free, speed, power, norm, speed_weight, direction_weight, inv_n,
              grad, b0, b1, fade=DIRECTION_FADE):  # pragma: no cover - numba
    """Samples ``b0:b1`` of :func:`loss_and_grad`: their gradient into ``grad`` and their
    share of the loss, given ``inv_n``, the inverse count of all free cells (float32)."""
    M = pred.shape[2]
    one = np.float32(1.0)
    tiny = np.float32(1e-30)
    terms = np.empty(M, np.float32)  # the cells' terms, summed after the loop over cells
    total = 0.0
    for b in range(b0, b1):
        u = max(float(speed[b]), 0.1)
        by_speed = (u / SPEED_REF) ** power
        soft = np.float32((1e-3 * u) ** 2)
        w_norm = np.float32(by_speed / u if norm else 0.0)
        w_sq = np.float32(0.0 if norm else by_speed / (u * u))
        w_sq2 = np.float32(2.0) * w_sq
        w_speed = np.float32(speed_weight * by_speed / u)
        w_dir = np.float32(direction_weight)
        eps = np.float32(1e-6 * u * u)
        # the direction term's weight min(1, |label| / (fade U)); fade 0: 1 wherever |label| > 0
        inv_slow = np.float32(1.0 / (fade * u)) if fade > 0.0 else np.float32(3.0e38)
        p0s, p1s, l0s, l1s = pred[b, 0], pred[b, 1], labels[b, 0], labels[b, 1]
        g0s, g1s, fs = grad[b, 0], grad[b, 1], free[b]
        for m in range(M):
            p0, p1, l0, l1 = p0s[m], p1s[m], l0s[m], l1s[m]
            d0 = p0 - l0
            d1 = p1 - l1
            sq = d0 * d0 + d1 * d1
            err = math.sqrt(sq + soft)
            term = w_norm * err + w_sq * sq
            k = w_norm / err + w_sq2
            g0 = k * d0
            g1 = k * d1
            # the speed term: d|p|/dp = p / |p|
            pp = p0 * p0 + p1 * p1
            ll = l0 * l0 + l1 * l1
            sp = math.sqrt(pp + soft)
            diff = sp - math.sqrt(ll + soft)
            term += w_speed * abs(diff)
            k = w_speed * np.float32((diff > 0) - (diff < 0)) / sp
            g0 += k * p0
            g1 += k * p1
            # the direction term 1 - cos: d(-cos)/dp = (p . l) |l| p / (|p| den^2) - l / den
            nl = math.sqrt(ll)
            c = w_dir * min(nl * inv_slow, one)
            npred = math.sqrt(pp)
            rden = one / (npred * nl + eps)
            dot = p0 * l0 + p1 * l1
            term += c * (one - dot * rden)
            q = dot * nl * rden * rden / max(npred, tiny)
            g0 += c * (q * p0 - l0 * rden)
            g1 += c * (q * p1 - l1 * rden)
            f = fs[m]
            terms[m] = f * term
            g0s[m] = f * inv_n * g0
            g1s[m] = f * inv_n * g1
        for m in range(M):
            total += terms[m]
    return total * inv_n


def loss_and_grad(pred, labels, free, speed, power, norm, speed_weight, direction_weight,
                  grad, fade=DIRECTION_FADE):
    """The loss of ``pred`` (B, 2, M) against ``labels`` (B, 2, M) over the cells where
    ``free`` (B, M) is 1, inlet speeds ``speed`` (B,) m/s, all float32; its gradient with
    respect to ``pred`` into ``grad`` (B, 2, M). ``norm``: the vector term is ``|pred - label|
    / U`` (softened by ``1e-3 U``), else ``|pred - label|^2 / U^2``; the direction term fades
    out in cells slower than ``fade`` U (weight ``min(1, |label| / (fade U))``; 0: no fade).
    Returns the loss.

    Float32 arithmetic without branches in the loop over cells (every term is computed, a
    weight of 0 drops it), so that the loop vectorises; the sum over cells is float64.

    The count of free cells is its own compiled pass (:func:`free_count`) and the loop over
    the samples runs between bounds given as arguments (:func:`loss_rows`): written as one
    function with ``range(B)``, the same arithmetic, to the bit, took 2.6-2.8 ms instead of
    0.64-0.75 for 256 samples of 625 cells on an Intel Xeon (2026-12-03; LLVM's code for
    the two loops differs, not the operations).
    """
    inv_n = np.float32(1.0 / max(free_count(free), 1))
    return loss_rows(pred, labels, free, speed, float(power), bool(norm), float(speed_weight),
                     float(direction_weight), inv_n, grad, 0, pred.shape[0], float(fade))


@functools.cache
def _loss_function():
    """The torch autograd Function of :func:`fused_loss`, built once (torch is imported only
    when a model trains)."""
    import torch

    class FusedLoss(torch.autograd.Function):
        @staticmethod
        def forward(ctx, p, labels, free, speed, power, norm, speed_weight, direction_weight,
                    fade):
            arrays = [np.ascontiguousarray(t.detach().numpy(), dtype=np.float32)
                      for t in (p, labels, free, speed)]
            grad = np.empty_like(arrays[0])
            value = loss_and_grad(*arrays, power, norm, speed_weight, direction_weight, grad,
                                  fade)
            ctx.save_for_backward(torch.from_numpy(grad))
            return p.new_tensor(value)

        @staticmethod
        def backward(ctx, g):
            (grad,) = ctx.saved_tensors
            # a plain loss's backward starts from g = 1: the gradient itself, not a pass
            # over the field that multiplies it by 1 (the same bits)
            if g.numel() == 1 and float(g) == 1.0:
                return grad, None, None, None, None, None, None, None, None
            return grad * g, None, None, None, None, None, None, None, None

    return FusedLoss


def fused_loss(pred, labels, free, speed, power: float, direction_weight: float,
               vector: str = "squared", speed_weight: float = 0.0,
               fade: float = DIRECTION_FADE):
    """The loss of :func:`windnav.predict.train._loss` with ``direction = "cosine"``, as a
    torch scalar whose backward is the gradient computed with it (CPU tensors, float32)."""
    return _loss_function().apply(pred, labels, free, speed, float(power), vector == "norm",
                                  float(speed_weight), float(direction_weight), float(fade))
