"""The wind flow decoder: NumPy inference of the local mean wind field (thesis chapter 4).

``Psi(D, W_up, W_robot) -> (u, v)`` on an ``H x H`` grid of spacing ``Delta`` centred on the
robot and aligned with the world axes, from one 360-ray LiDAR scan ``D`` (ray ``k`` at ``k``
deg counter-clockwise from +x), the free-stream wind ``W_up`` and the time-averaged wind at the
robot ``W_robot`` (both world frame, m/s). This module owns the model file format and the
NumPy forward pass of every architecture; training (torch) lives in
:mod:`windnav.predict.torch_models` and :mod:`windnav.predict.train` and is never imported here.

Architectures
-------------
``thesis-mlp``
    The thesis's MLP, 364 -> depth x width (ReLU) -> 2 H^2 (11.7 M parameters at width 2048,
    depth 3, H = 25). Inputs ``[D / 100 m, W_up / 10 m/s, W_robot / 10 m/s]``; outputs are
    multiplied by the same 10 m/s. About 23 MFLOP per sample. The ``winds`` hyperparameter
    (default ``"both"``; ``"up"``, ``"robot"``, ``"none"``) holds the winds not given at
    0: the inputs ablation of :mod:`windnav.experiments.decoder_studies`.

``d4-film`` (designed for a CPU)
    The same mapping with the symmetries and scales of the problem built in, so that the
    parameters go to what cannot be derived: 0.15 M parameters at the default widths, about
    0.33 MFLOP per sample as executed (the convolution runs as banded block products).

    1. *Canonical frame: exact D4 equivariance.* The maps are rectangles on a square grid and
       the solver's grid is square, so rotating the world by 90 deg or mirroring it
       (y -> -y) rotates or mirrors the mean flow. One of the 8 elements ``g`` of the dihedral
       group D4 maps the direction of ``W_up`` into the sector [0, 45] deg, and the network
       works in that frame. On a 1-degree scan the action is exact: a 90 deg rotation is a
       shift of 90 rays and the mirror is ray k -> -k; the winds are multiplied by the
       integer matrix ``A_g``; the grid goes back by the inverse cell permutation (a
       ``np.rot90``/flip) and ``A_g^T`` on the components,
       ``u_world(p) = A_g^T u_canonical(A_g p)``. The decoder is therefore equivariant by
       construction (a rotated or mirrored scenario gives the rotated or mirrored
       prediction), it meets 8 times fewer distinct situations, and a sweep over a few inlet
       directions covers the circle once folded. What is left of the direction, the angle
       ``beta`` of ``W_up`` in [0, 45] deg, enters as a feature.
    2. *Speed scaling: exact self-similarity.* The solver (:func:`windnav.flow.simulate`) has
       no fixed viscosity (a Smagorinsky eddy viscosity ``(C_s Delta)^2 |S|`` and inviscid
       walls), so it has no velocity scale: the flow at inlet speed ``lambda U`` is the flow
       at ``U`` with velocities times ``lambda`` and time divided by ``lambda``, and with the
       default time step (``U dt / dx = 1`` for U >= 4 m/s) the mean fields of all those
       speeds are the same field scaled. So the winds enter divided by
       ``U = max(|W_up|, speed_floor)``, the learned part of the output is multiplied by U,
       and the decoder is exactly homogeneous: ``Psi(D, l W_up, l W_robot) = l Psi(D, W_up,
       W_robot)`` for ``l > 0`` (while ``|W_up| >= speed_floor``). A sweep then needs one
       inlet speed per direction.
    3. *Residual on the Local baseline.* The output is ``W_robot + U * r``: the model starts
       from the uniform ``W_robot`` (the Local baseline) and learns the spatial deviation
       ``r`` (the truth has ``r = 0`` at the robot).
    4. *Scan encoder.* The scan is min-pooled into ``n_rays / pool`` sectors centred on
       multiples of ``pool`` deg (odd ``pool`` dividing 90: these sectors are permuted, not
       cut, by D4, so pooling commutes with the frame change and is done first, on 5 times
       less data); each sector's nearest wall becomes two channels (range / 100 m and its
       log), then one circular 1D convolution (ReLU), a max-pool of 2 and one dense layer.
       The convolution finds walls and corners wherever they are; the dense layer knows
       where they are relative to the wind (the frame is canonical, so position on the ring
       has a meaning).
    5. *FiLM.* The five wind features (``W_up / U = (cos beta, sin beta)``, ``W_robot / U``,
       ``|W_robot| / U``) scale and shift the scan embedding
       (``h = relu(e (1 + gamma) + beta)``, Perez et al. 2018) and also enter the trunk: how
       the same buildings shape the flow depends on where the wind comes from.
    6. *Mode decoder.* The trunk ends in ``modes`` coefficients of a linear basis of
       ``2 H^2`` cells (the thesis finds 16 PCA eigenflows explain >= 98 % of the variance of
       the local fields). Training initialises the basis with the principal components of
       the training residuals, so the first step already predicts the mean pattern.

    7. *Members (an ensemble).* With the ``members`` hyperparameter M > 1 the file holds M
       such models trained from different seeds (``member{i}.<name>``, :func:`ensemble_decoder`)
       and the prediction is the mean of their fields. Since each field is linear in its mode
       coefficients, the mean is one product: the members' coefficients side by side against
       their bases stacked (each divided by M). The members' errors are partly independent,
       so their mean is closer to the truth than each (never farther in the mean vector
       error: ``|mean(p) - u| <= mean(|p - u|)``).

    The NumPy forward folds the frame change into the basis: for each of the 8 elements it
    keeps the basis with its cells permuted and its components rotated back, so a batch is
    decoded straight into the world frame, group by group (no gather over the output).
    Nearly all the cost is then matrix products at BLAS speed: the convolution (one block
    matrix applied to every block of sectors' window, :func:`conv_block`), the dense scan
    layer, the trunk and the basis.

File format
-----------
One ``.npz`` (no pickles) with one float32 array per parameter, named as in the torch
module's ``state_dict``, and ``__metadata__``: a JSON string with ``format``
(``"windnav-decoder"``), ``version`` (:data:`FORMAT_VERSION`), ``architecture``,
``hyperparameters`` (with ``size``, the input scales and ``n_rays``), ``spacing`` (m) and, when
made by training, ``recipe``, ``metrics`` and ``training`` summaries.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import warnings
import zipfile
from pathlib import Path

import numpy as np

from windnav._validate import ReadOnlyOnCopy
from windnav.predict.baselines import N_RAYS, check_inputs
from windnav.predict.dataset import SCAN_MIN, grid_offsets

__all__ = [
    "ARCHITECTURES",
    "BLEND_WIDTH_DEG",
    "BOUNDARIES",
    "DEFAULT_MODEL",
    "FORMAT",
    "FORMAT_VERSION",
    "ROTATIONS_LIMIT_DEG",
    "D4FilmArchitecture",
    "Decoder",
    "ThesisMLPArchitecture",
    "boundary_side",
    "canonical_elements",
    "canonicalize",
    "canonicalize_field",
    "centred_min_pool",
    "check_rotations",
    "conv_block",
    "d4_grid_permutation",
    "d4_matrices",
    "d4_ring_indices",
    "ensemble_decoder",
    "load_decoder",
    "make_architecture",
    "member_weights",
    "model_sha256",
    "on_sector_boundary",
    "permute_cells",
    "rotation_resampler",
    "save_decoder",
    "sector_boundary_distance_deg",
    "shipped_model_file",
    "turn_field_back",
    "turned_inputs",
    "uncanonicalize",
    "wind_features",
    "upstream_features",
    "robot_features",
]

FORMAT = "windnav-decoder"
FORMAT_VERSION = 1
METADATA_KEY = "__metadata__"
DEFAULT_MODEL = Path(__file__).resolve().parent / "data" / "decoder_default.npz"
DEFAULT_RECIPE = "src/windnav/predict/recipes/default.toml"


def model_sha256(path=None) -> str:
    """The SHA-256 (64 hex digits) of the decoder file ``path`` (default: the shipped model's,
    :data:`DEFAULT_MODEL`). A result records it beside the path it read (since 2026-12-06,
    the forty-seventh session): a path names a file whose content can change, and the default
    names a new model each time one is shipped (:mod:`windnav.provenance`)."""
    with open(DEFAULT_MODEL if path is None else Path(path), "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


def shipped_model_file(sha256: str) -> Path | None:
    """The decoder file installed with windnav whose SHA-256 is ``sha256``: the shipped
    model's (:data:`DEFAULT_MODEL`) or one of the dated files kept of the models it replaced
    (``decoder_<label>.npz`` beside it); None when none is."""
    folder = DEFAULT_MODEL.parent
    for path in [DEFAULT_MODEL, *sorted(set(folder.glob("decoder_*.npz")) - {DEFAULT_MODEL})]:
        if path.is_file() and model_sha256(path) == sha256:
            return path
    return None


N_WIND_FEATURES = 5
"""Wind features of d4-film (see :func:`wind_features`)."""
PREDICT_CHUNK = 128
"""Samples per forward pass in :meth:`Decoder.predict`: a larger batch's mode coefficients are
computed in chunks of this many, and its fields written in groups of at most this many rows of
one D4 element (since 2026-12-07, :meth:`D4FilmArchitecture.expand`). Why: one pass over 1,024
samples allocates about 25 MB of temporaries, more than glibc's malloc keeps between calls, so
every call's arrays came back as fresh pages from the kernel: 18.8 ms per 1,024 on one thread of
the AMD EPYC in a fresh process, 9.2 ms only after some large free had raised malloc's
thresholds (as the thesis MLP's construction did in ``benchmarks/bench_decoder.py``). In chunks
of 128 the working set is reused: 11.5 ms in both states (2026-12-02, docs/decoder.md; chunks of
64, 96, 192, 256, 512: 14.3, 12.5-12.9, 10.9-15.7, 10.1-14.9, 16.2-17.8 ms, the first figure in
a fresh process where they differ). A chunk's rows agree with the whole batch's to float32
rounding (the matrix products' blocking differs)."""

BOUNDARIES = ("average", "floor", "blend")
"""How :meth:`Decoder.predict` treats a free-stream direction on a sector boundary of the
d4-film's frame (a multiple of 45 deg: 0, 45, 90, ... 315), where two of its symmetries take
the wind into [0, 45] deg and the network, never made symmetric there, answers differently
through each (up to 14 m/s in a cell, 0.6 m/s on average, on a real map):

- ``"average"`` (one pass off the boundaries: :class:`Decoder`'s default, the rule training
  validates with, and :func:`load_decoder`'s until 2026-12-06): the mean of the two, each at
  the boundary's side
  (:data:`BOUNDARY_NUDGE_DEG`): the answer is the same for 0 and 360 deg and mirrors with the
  scene, as the decoder's symmetry promises everywhere else;
- ``"floor"``: the sector ``floor(angle / 45)`` of the direction as rounding leaves it (0 deg
  and 360 deg, whose sine rounds to -1e-15, fall on either side). The navigation benchmark's
  onboard stack flew its recorded flights so (the suite's incidences are 0, 15, 30 and 45 deg),
  and :func:`windnav.experiments.nav_benchmark.benchmark_decoder` keeps it, so they replay;
- ``"blend"`` (:func:`load_decoder`'s default since 2026-12-06):
  ``"average"`` on a boundary, and within :data:`BLEND_WIDTH_DEG` of one
  the network's answer through the direction's own symmetry blended with its answer through
  the other side's, weight ``(1 - |s| / BLEND_WIDTH_DEG) / 2`` on the other at a distance
  ``s`` from the boundary: the field is then continuous in the inlet direction, where with the
  other rules it jumps across a boundary (2.0-2.7 m/s on average at 6 m/s on a dense map,
  ``docs/decoder.md``, "Turned views"). Those samples take a second pass: 12.9 against 8.9 ms
  per 1,024 random inlets on one thread, the windinet errors 2.1 % (speed) and 1.6 %
  (direction) lower (docs/decoder.md, "Blended folds"). Training validates and scores the one
  pass (``"average"``), the rule the results committed before that day were made with."""

BLEND_WIDTH_DEG = 8.0
"""How far from a sector boundary ``boundary="blend"`` blends the two symmetries' answers, deg:
chosen on the default recipe's held-out district (16 inlets; among 1, 2, 3, 5, 8, 12 and 22.5
deg, the lowest mean of the speed and direction error ratios to one pass:
``docs/data/decoder_fold_blend.json``). Wider, the other symmetry answers inlets farther
outside the sector it was trained in, and the error grows again."""

BOUNDARY_TOLERANCE_DEG = 1e-4
"""A free-stream direction within this of a multiple of 45 deg is on the boundary, deg."""

BOUNDARY_NUDGE_DEG = 1e-3
"""How far to either side of a boundary :data:`BOUNDARIES` ``"average"`` evaluates the two
sides, deg (above float32's resolution of the angle near 360 deg, 3e-5 deg)."""
SHORT_RANGE_TIES = 3
"""Rays of one scan at exactly its largest range, under the decoder's ``range_scale``, from
which :meth:`Decoder.predict` warns of a LiDAR whose misses read a shorter maximum range (a
scan of :meth:`windnav.city.City.lidar`'s 100 m reads 100 m on its misses; noisy hits never tie
three times)."""

CONV_BLOCK_MAX = 12
"""The largest block of sectors of the banded scan convolution (:func:`conv_block`)."""

ROTATIONS_LIMIT_DEG = 45.0
"""The largest turn of the scene :meth:`Decoder.predict` averages over (``rotations_deg``),
deg. At any turn some edge cells of the output grid come from points beyond the window the
model predicts, and take the nearest edge cell's value: 48 of the 625 cells of the 25-cell
grid at 1-3 deg, 68 at 10 deg, 144 at 45 deg. Wider turns also take the street grid further
from the training maps' (on the held-out district, views at 0 and +-8 deg were already worse
than one pass on speed, docs/decoder.md, "Turned views"); beyond 45 deg a quarter turn the
other way is the same view, exactly, for the d4-film."""


# ------------------------------------------------------------------------------ D4 frames


def d4_matrices() -> np.ndarray:
    """The 8 elements of D4 as integer 2x2 matrices ``A_g = R(90 k) M^m``, ``g = 4 m + k``.

    ``M = diag(1, -1)`` mirrors y -> -y; ``R(90 k)`` rotates by ``90 k`` deg. On a direction
    angle the element acts as ``theta -> (-1)^m theta + 90 k``.

    Returns
    -------
    ndarray of shape (8, 2, 2), float32
        Entries 0 and +-1, so products with them are exact.
    """
    out = np.empty((8, 2, 2), dtype=np.float32)
    mirror = np.diag([1.0, -1.0])
    for m in range(2):
        for k in range(4):
            c, s = [(1, 0), (0, 1), (-1, 0), (0, -1)][k]
            rot = np.array([[c, -s], [s, c]], dtype=np.float64)
            out[4 * m + k] = rot @ (mirror if m else np.eye(2))
    return out


_D4 = d4_matrices()
_D4_T = np.ascontiguousarray(_D4.transpose(0, 2, 1))  # inverses


def canonical_elements(w_up: np.ndarray) -> np.ndarray:
    """The D4 element taking each free-stream direction into the sector [0, 45] deg.

    Parameters
    ----------
    w_up : ndarray of shape (B, 2)
        Free-stream wind, world frame, m/s.

    Returns
    -------
    ndarray of shape (B,), int64
        ``g = 4 m + k`` (see :func:`d4_matrices`): ``A_g w_up`` points into [0, 45] deg.
        Sector ``s = floor(alpha / 45 deg)`` of the direction ``alpha`` in [0, 360): an even
        ``s = 2 j`` is rotated by ``-90 j``; an odd ``s = 2 j + 1`` is mirrored, then rotated
        by ``90 (j + 1)``. A zero wind gets the identity.
    """
    alpha = np.degrees(np.arctan2(w_up[:, 1], w_up[:, 0])) % 360.0
    sector = np.minimum((alpha // 45.0).astype(np.int64), 7)
    j, odd = sector // 2, sector % 2
    k = np.where(odd == 1, (j + 1) % 4, (-j) % 4)
    return 4 * odd + k


def _check_boundary(boundary, where: str) -> str:
    """``boundary`` if it is one of :data:`BOUNDARIES`, else a ValueError naming ``where``."""
    if boundary not in BOUNDARIES:
        raise ValueError(f"The 'boundary' parameter of {where} must be one of "
                         f"{list(BOUNDARIES)}. Got {boundary!r} instead.")
    return boundary


def sector_boundary_distance_deg(direction_deg):
    """How far each direction lies from the nearest sector boundary of the d4-film's frame (a
    multiple of 45 deg), deg in [0, 22.5]; ``direction_deg`` a number or array, deg."""
    return np.abs(_boundary_offset_deg(direction_deg))


def _boundary_offset_deg(direction_deg):
    """Each direction minus its nearest multiple of 45 deg, deg in [-22.5, 22.5] (signed)."""
    alpha = np.asarray(direction_deg, dtype=np.float64)
    return alpha - 45.0 * np.round(alpha / 45.0)


def on_sector_boundary(w_up: np.ndarray) -> np.ndarray:
    """Whether each free-stream wind's direction lies within :data:`BOUNDARY_TOLERANCE_DEG`
    of a multiple of 45 deg (a zero wind does not), ``(B,)`` bool."""
    w = np.asarray(w_up, dtype=np.float64)
    off = sector_boundary_distance_deg(np.degrees(np.arctan2(w[:, 1], w[:, 0])))
    return (off < BOUNDARY_TOLERANCE_DEG) & (np.hypot(w[:, 0], w[:, 1]) > 0)


def boundary_side(w_up: np.ndarray, sign: float) -> np.ndarray:
    """Winds on a sector boundary turned to its ``sign`` side (+1: counter-clockwise) by
    :data:`BOUNDARY_NUDGE_DEG` from the exact multiple of 45 deg, their speeds kept."""
    w = np.asarray(w_up, dtype=np.float64)
    alpha = np.radians(45.0 * np.round(np.degrees(np.arctan2(w[:, 1], w[:, 0])) / 45.0)
                       + sign * BOUNDARY_NUDGE_DEG)
    return np.hypot(w[:, 0], w[:, 1])[:, None] * np.column_stack([np.cos(alpha),
                                                                  np.sin(alpha)])


def check_rotations(rotations_deg, n_rays: int, where: str) -> tuple[float, ...] | None:
    """``rotations_deg`` as a tuple of floats (None stays None; -0 becomes 0), else a
    ValueError naming it: a non-empty flat sequence of finite real angles, deg (not strings or
    booleans), each a whole number of rays (a multiple of ``360 / n_rays``, so that the scan
    turns by an index shift) and within :data:`ROTATIONS_LIMIT_DEG` of 0."""
    if rotations_deg is None:
        return None
    items = (list(rotations_deg) if isinstance(rotations_deg, (list, tuple, np.ndarray))
             else None)
    if items is None or any(isinstance(v, (str, bytes, bool, np.bool_)) or np.ndim(v) != 0
                            for v in items):
        raise ValueError(f"The 'rotations_deg' parameter of {where} must be a flat sequence "
                         f"of angles, deg (e.g. (0, -3, 3)). Got {rotations_deg!r} instead.")
    try:
        values = np.array(items, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"The 'rotations_deg' parameter of {where} must be a flat sequence "
                         f"of angles, deg. Got {rotations_deg!r} instead ({exc}).") from exc
    if values.size == 0 or not np.all(np.isfinite(values)):
        raise ValueError(f"The 'rotations_deg' parameter of {where} must hold at least one "
                         f"finite angle, deg. Got {rotations_deg!r} instead.")
    step = 360.0 / n_rays
    rays = values / step
    if np.any(np.abs(rays - np.round(rays)) > 1e-9) or np.any(
            np.abs(values) > ROTATIONS_LIMIT_DEG):
        raise ValueError(f"The 'rotations_deg' parameter of {where} must hold whole multiples "
                         f"of the ray spacing ({step:g} deg) within {ROTATIONS_LIMIT_DEG:g} deg "
                         f"of 0. Got {rotations_deg!r} instead.")
    return tuple(float(v) + 0.0 for v in values)  # + 0.0: -0.0 is 0.0


def rotation_resampler(offsets: np.ndarray, angle_deg: float):
    """The bilinear map from a field on the grid to its values at the grid's cells turned by
    ``angle_deg`` counter-clockwise about offset 0 (the robot, the grid's centre for
    :func:`~windnav.predict.dataset.grid_offsets`): ``P`` (H^2, H^2), sparse, float32, with
    ``(P f)[p] = f(R p)`` for the cells ``p`` (row-major ``[iy, ix]``) and a point beyond the
    grid taking its nearest edge value. ``offsets`` (H,) are the cell centres, m, evenly
    spaced and the same for x and y."""
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    return linear_resampler(offsets, ((c, -s), (s, c)))


def linear_resampler(offsets: np.ndarray, matrix):
    """:func:`rotation_resampler` for any linear map ``A`` of the plane (``matrix``, 2 x 2):
    ``(P f)[p] = f(A p)``, bilinear, the nearest edge value beyond the grid (a turn, or a
    mirror such as the trial of ``docs/data/decoder_mirror_trial.py``)."""
    from scipy.sparse import csr_matrix

    off = np.asarray(offsets, dtype=np.float64)
    h = off.size
    if h == 1:  # one cell, the centre: a linear map leaves it where it is
        return csr_matrix(np.ones((1, 1), dtype=np.float32))
    spacing = off[1] - off[0]
    x, y = np.meshgrid(off, off)  # [iy, ix]
    (a, b), (c, d) = matrix
    fx = np.clip((a * x + b * y - off[0]) / spacing, 0.0, h - 1.0).ravel()
    fy = np.clip((c * x + d * y - off[0]) / spacing, 0.0, h - 1.0).ravel()
    x0 = np.minimum(np.floor(fx).astype(np.int64), h - 2)
    y0 = np.minimum(np.floor(fy).astype(np.int64), h - 2)
    tx, ty = fx - x0, fy - y0
    rows = np.repeat(np.arange(h * h), 4)
    cols = np.column_stack([y0 * h + x0, y0 * h + x0 + 1, (y0 + 1) * h + x0,
                            (y0 + 1) * h + x0 + 1]).ravel()
    vals = np.column_stack([(1 - tx) * (1 - ty), tx * (1 - ty), (1 - tx) * ty,
                            tx * ty]).ravel()
    return csr_matrix((vals.astype(np.float32), (rows, cols)), shape=(h * h, h * h))


def turned_inputs(scans: np.ndarray, w_up: np.ndarray, w_robot: np.ndarray,
                  angle_deg: float) -> tuple:
    """The scene turned ``angle_deg`` counter-clockwise, deg, a whole number of rays (as
    :func:`check_rotations` requires; another angle is rounded to the nearest ray): each scan
    ``(B, n_rays)`` m shifted by ``angle_deg n_rays / 360`` rays (the turned scan's ray ``k``
    is the scan's ray ``k`` minus that shift) and both winds ``(B, 2)`` m/s turned.

    Returns
    -------
    tuple of ndarray
        ``(scans, w_up, w_robot)`` of the turned scene, the same shapes (new arrays)."""
    n_rays = scans.shape[1]
    shift = int(round(angle_deg * n_rays / 360.0))
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    turn = np.array([[c, -s], [s, c]])
    return np.roll(scans, shift, axis=1), w_up @ turn.T, w_robot @ turn.T


def turn_field_back(field: np.ndarray, resampler, angle_deg: float) -> np.ndarray:
    """The field predicted in a scene turned ``angle_deg`` counter-clockwise, in the scene's
    own frame: ``u(p) = R^T u_turned(R p)``, ``field`` (B, 2, H, H) and ``resampler`` the
    angle's :func:`rotation_resampler`."""
    b, _, h, _ = field.shape
    at = (resampler @ field.reshape(b * 2, h * h).T).T.reshape(b, 2, h, h)
    c, s = np.float32(math.cos(math.radians(angle_deg))), np.float32(
        math.sin(math.radians(angle_deg)))
    return np.stack([c * at[:, 0] + s * at[:, 1], c * at[:, 1] - s * at[:, 0]], axis=1)


def d4_ring_indices(n: int) -> np.ndarray:
    """Permutations of ``n`` equally spaced directions (rays or centred sectors) under D4.

    Direction ``j`` is at ``360 j / n`` deg. The canonical direction ``j`` is the world
    direction ``A_g^-1(j) = (-1)^m (j - n k / 4)``, so ``ring_c = ring[:, idx[g]]``.

    Returns
    -------
    ndarray of shape (8, n), int64
    """
    if n % 4:
        raise ValueError(f"The 'n' parameter of d4_ring_indices must be a multiple of 4. "
                         f"Got {n!r} instead.")
    j = np.arange(n)
    out = np.empty((8, n), dtype=np.int64)
    for m in range(2):
        for k in range(4):
            out[4 * m + k] = ((-1) ** m * (j - (n // 4) * k)) % n
    return out


def d4_grid_permutation(size: int) -> np.ndarray:
    """Cell permutations of the 8 elements on the centred ``size x size`` grid.

    ``perm[g, c]`` is the flat index (``iy * size + ix``) of the cell ``A_g p`` for the cell
    ``c`` at offset ``p``: ``field_world[..., c] = A_g^T field_c[..., perm[g, c]]``.

    Returns
    -------
    ndarray of shape (8, size * size), int64
    """
    c = 2 * np.arange(size) - (size - 1)  # centred integer coordinates: exact for any H
    px, py = np.meshgrid(c, c)  # [iy, ix]
    pts = np.stack([px.ravel(), py.ravel()])
    out = np.empty((8, size * size), dtype=np.int64)
    for g, a in enumerate(_D4.astype(np.int64)):
        q = a @ pts
        out[g] = (q[1] + size - 1) // 2 * size + (q[0] + size - 1) // 2
    return out


def canonicalize(scans, w_up, w_robot):
    """Inputs in the canonical frame of each sample (the reference frame change).

    Parameters
    ----------
    scans : ndarray of shape (B, n_rays)
        Ranges, m, world frame (``n_rays`` a multiple of 4).
    w_up, w_robot : ndarray of shape (B, 2)
        Winds, m/s, world frame.

    Returns
    -------
    g : ndarray of shape (B,), int64
    scans_c : ndarray of shape (B, n_rays)
    w_up_c, w_robot_c : ndarray of shape (B, 2)
        ``A_g w``; ``w_up_c`` points into [0, 45] deg.
    """
    g = canonical_elements(w_up)
    scans_c = np.take_along_axis(scans, d4_ring_indices(scans.shape[1])[g], axis=1)
    mats = _D4[g]
    return (g, scans_c, np.einsum("bij,bj->bi", mats, w_up),
            np.einsum("bij,bj->bi", mats, w_robot))


def uncanonicalize(field_c: np.ndarray, g: np.ndarray) -> np.ndarray:
    """Canonical fields ``(B, 2, H^2)`` back in the world frame, ``(B, 2, H^2)`` (exact)."""
    size = math.isqrt(field_c.shape[2])
    cells = permute_cells(field_c, d4_grid_permutation(size), g)
    return np.einsum("bij,bjn->bin", _D4_T[g], cells)


def permute_cells(a: np.ndarray, perms: np.ndarray, g: np.ndarray) -> np.ndarray:
    """``a`` (B, ..., N) with the last axis of sample ``b`` gathered by ``perms[g[b]]`` (``perms``
    (8, N)): ``take_along_axis`` with ``perms[g]``, the same values, one ``take`` per D4 element
    present instead of an index array of ``a``'s size (the gathers of a training block's turn
    into the model frame, 552,960 labels and free masks: 3.1 s against 8.0 s on an Intel Xeon,
    2026-12-03)."""
    out = np.empty_like(a)
    for e in np.unique(g):
        rows = np.flatnonzero(g == e)
        out[rows] = np.take(a[rows], perms[e], axis=-1)
    return out


def canonicalize_field(field: np.ndarray, g: np.ndarray) -> np.ndarray:
    """World fields ``(B, 2, H^2)`` in the canonical frame (the inverse of
    :func:`uncanonicalize`)."""
    size = math.isqrt(field.shape[2])
    cells = permute_cells(field, np.argsort(d4_grid_permutation(size), axis=1), g)
    return np.einsum("bij,bjn->bin", _D4[g], cells)


# ------------------------------------------------------------------------- features


def conv_block(n: int) -> int:
    """Output sectors per block of the banded convolution of ``d4-film`` on ``n`` sectors.

    The largest even divisor of ``n`` up to :data:`CONV_BLOCK_MAX` (even: the max-pool of 2
    stays within a block). Each block costs a product with a ``(2 (P + K - 1), P C)`` matrix,
    so small blocks waste less on the window's overlap and large ones run the product longer;
    on 72 sectors, one thread, per 1,024 samples (with the pool and the bias): P = 4: 1.17 ms,
    8: 1.05, 12: 1.04, 24: 1.26, and the dense circulant product (P = 72) 2.24 ms
    (2026-12-02).
    """
    return max(p for p in range(2, min(n, CONV_BLOCK_MAX) + 1, 2) if n % p == 0)


def centred_min_pool(scans: np.ndarray, pool: int) -> np.ndarray:
    """Nearest range in each sector of ``pool`` rays centred on ray ``pool * i``.

    Parameters
    ----------
    scans : ndarray of shape (B, n_rays)
    pool : int
        Odd, dividing ``n_rays``.

    Returns
    -------
    ndarray of shape (B, n_rays / pool)
        Sector ``i`` is the minimum of rays ``pool * i - h ... pool * i + h``,
        ``h = (pool - 1) / 2`` (circularly).
    """
    h = (pool - 1) // 2
    n = scans.shape[1]
    shifted = np.concatenate([scans[:, n - h:], scans[:, :n - h]], axis=1) if h else scans
    return _run_min(shifted, pool)


def _run_min(values: np.ndarray, pool: int) -> np.ndarray:
    """The minimum of each run of ``pool`` consecutive columns: ``(B, pool n) -> (B, n)``.

    ``pool - 1`` elementwise minima of strided columns, not a reduction over a trailing axis of
    ``pool``, which costs several times as much; the minimum is exact in any order.
    """
    out = values[:, 0::pool].copy()
    for j in range(1, pool):
        np.minimum(out, values[:, j::pool], out=out)
    return out


def range_channels(ranges: np.ndarray, range_scale: float, range_min: float) -> np.ndarray:
    """Ranges ``(B, N)`` m as two channels ``(B, 2, N)`` in [0, 1]: ``r / range_scale`` and
    ``log(r / range_min) / log(range_scale / range_min)``, ``r`` clipped to the scan's range."""
    # np.clip's values (bounds > 0: no signed-zero tie), without its wrapper's cost
    r = np.minimum(np.maximum(ranges, np.float32(range_min)), np.float32(range_scale))
    span = np.float32(math.log(range_scale / range_min))
    return np.stack([r / np.float32(range_scale), np.log(r / np.float32(range_min)) / span],
                    axis=1)


def wind_features(w_up_c: np.ndarray, w_robot_c: np.ndarray, speed_floor: float):
    """The five canonical wind features and the speed scale ``U``.

    Returns
    -------
    features : ndarray of shape (B, 5), float32
        ``W_up / U`` (2), ``W_robot / U`` clipped to +-4 (2), ``|W_robot| / U`` clipped to
        [0, 4].
    scale : ndarray of shape (B,), float32
        ``U = max(|W_up|, speed_floor)``, m/s.
    """
    up, scale = upstream_features(w_up_c, speed_floor)
    return robot_features(up, w_robot_c, scale), scale


def upstream_features(w_up_c: np.ndarray, speed_floor: float):
    """``W_up / U`` (B, 2) and ``U`` (B,), float32: the part of :func:`wind_features` that
    depends on the inlet wind alone."""
    w_up_c = np.asarray(w_up_c, dtype=np.float32)
    scale = np.maximum(np.hypot(w_up_c[:, 0], w_up_c[:, 1]), np.float32(speed_floor))
    return w_up_c / scale[:, None], scale


def robot_features(up: np.ndarray, w_robot_c: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """The five features of :func:`wind_features` from its upstream part
    (:func:`upstream_features`) and the canonical ``W_robot`` (B, 2), float32."""
    w_robot_c = np.asarray(w_robot_c, dtype=np.float32)
    rob = np.minimum(np.maximum(w_robot_c / scale[:, None], -4.0), 4.0)  # np.clip's values
    rob_speed = np.minimum(np.hypot(w_robot_c[:, 0], w_robot_c[:, 1]) / scale, 4.0)
    feats = np.concatenate([up, rob, rob_speed[:, None]], axis=1)
    return feats.astype(np.float32, copy=False)


# --------------------------------------------------------------------- architectures


class ThesisMLPArchitecture:
    """The ``thesis-mlp`` (see the module docstring): world frame, constant input scales.

    Every architecture has the same parts: ``shapes()`` (parameter name -> shape),
    ``features(scans, w_up, w_robot)`` (the NumPy preprocessing, shared with training),
    ``prepare(weights)`` (the weights plus arrays derived from them once),
    ``network(prepared, features)`` (the learned part, mirrored by
    :mod:`windnav.predict.torch_models`; a model-frame field ``(B, 2, H^2)``, m/s),
    ``world_frame(field, features)`` (to ``(B, 2, H, H)``), ``model_labels(labels, free,
    features)`` (world labels into the model frame, for training) and ``predict(prepared,
    scans, w_up, w_robot)`` (the inference path, world frame in and out).

    Parameters
    ----------
    hp : dict
        Complete hyperparameters (:func:`make_architecture`).
    """

    name = "thesis-mlp"
    defaults = {"n_rays": 360, "width": 2048, "depth": 3, "range_scale": 100.0,
                "wind_scale": 10.0, "winds": "both"}

    def __init__(self, hp: dict):
        self.hp = hp

    def shapes(self) -> dict:
        hp = self.hp
        dims = [hp["n_rays"] + 4] + [hp["width"]] * hp["depth"] + [2 * hp["size"] ** 2]
        shapes = {}
        for i in range(len(dims) - 1):
            shapes[f"layers.{i}.weight"] = (dims[i + 1], dims[i])
            shapes[f"layers.{i}.bias"] = (dims[i + 1],)
        return shapes

    def features(self, scans, w_up, w_robot) -> dict:
        rs, ws = np.float32(self.hp["range_scale"]), np.float32(self.hp["wind_scale"])
        x = np.concatenate([np.minimum(scans, rs) / rs, w_up / ws, w_robot / ws], axis=1)
        # the winds ablation (hyperparameter "winds"): a wind not given is an input held at 0
        n = scans.shape[1]
        if self.hp.get("winds", "both") in ("none", "robot"):
            x[:, n:n + 2] = 0.0
        if self.hp.get("winds", "both") in ("none", "up"):
            x[:, n + 2:n + 4] = 0.0
        return {"x": x.astype(np.float32, copy=False)}

    def network(self, w: dict, f: dict) -> np.ndarray:
        x = f["x"]
        n = self.hp["depth"] + 1
        for i in range(n):
            x = x @ w[f"layers.{i}.weight"].T + w[f"layers.{i}.bias"]
            if i < n - 1:
                np.maximum(x, 0.0, out=x)
        return (x * np.float32(self.hp["wind_scale"])).reshape(x.shape[0], 2, -1)

    def world_frame(self, field: np.ndarray, f: dict) -> np.ndarray:
        h = self.hp["size"]
        return field.reshape(-1, 2, h, h)

    def model_labels(self, labels: np.ndarray, free: np.ndarray, f: dict):
        return labels, free

    def prepare(self, w: dict) -> dict:
        return dict(w)

    def predict(self, w: dict, scans, w_up, w_robot) -> np.ndarray:
        return self.world_frame(self.network(w, self.features(scans, w_up, w_robot)), None)


class D4FilmArchitecture(ThesisMLPArchitecture):
    """The ``d4-film`` architecture (see the module docstring): canonical frame, speed scaling,
    circular-convolution scan encoder, FiLM, residual mode decoder."""

    name = "d4-film"
    defaults = {"n_rays": 360, "pool": 5, "conv_channels": 8, "kernel": 5, "embed": 128,
                "film_hidden": 32, "width": 128, "depth": 2, "modes": 48,
                "range_scale": 100.0, "range_min": 0.25, "speed_floor": 0.1, "members": 1}

    def __init__(self, hp: dict):
        super().__init__(hp)
        self._bins = d4_ring_indices(hp["n_rays"] // hp["pool"])
        self._perm = d4_grid_permutation(hp["size"])
        self._inverse = np.argsort(self._perm, axis=1)
        # the rays pooled into canonical sector i for element g: centred_min_pool's sector
        # bins[g, i], rays pool * bins[g, i] - h ... + h, h = (pool - 1) / 2 (circularly);
        # (8, sectors * pool), each sector's rays consecutive
        pool, h = hp["pool"], (hp["pool"] - 1) // 2
        self._sector_rays = ((pool * self._bins[:, :, None] + np.arange(pool) - h)
                             % hp["n_rays"]).reshape(8, -1)
        # the banded convolution (coefficients): blocks of conv_block(n) output sectors, each
        # from its window of block + kernel - 1 input sectors per channel (circularly)
        n, k = hp["n_rays"] // pool, hp["kernel"]
        self._block = conv_block(n)
        span = self._block + k - 1
        starts = np.arange(0, n, self._block) - k // 2
        self._conv_windows = (np.arange(2)[None, :, None] * n + (
            starts[:, None, None] + np.arange(span)[None, None, :]) % n).reshape(-1)
        self._upstream_memo = None

    def shapes(self) -> dict:
        """Parameter name -> shape; with ``members`` M > 1, each member's under
        ``member{i}.`` (:func:`member_weights`)."""
        one = self._member_shapes()
        if self.hp["members"] == 1:
            return one
        return {f"member{i}.{k}": s for i in range(self.hp["members"]) for k, s in one.items()}

    def _member_shapes(self) -> dict:
        hp = self.hp
        c, k, e, width = hp["conv_channels"], hp["kernel"], hp["embed"], hp["width"]
        n_pooled = hp["n_rays"] // hp["pool"] // 2
        shapes = {
            "conv.weight": (c, 2, k), "conv.bias": (c,),
            "embed.weight": (e, n_pooled * c), "embed.bias": (e,),
            "film_in.weight": (hp["film_hidden"], N_WIND_FEATURES),
            "film_in.bias": (hp["film_hidden"],),
            "film_out.weight": (2 * e, hp["film_hidden"]), "film_out.bias": (2 * e,),
        }
        n_in = e + N_WIND_FEATURES
        for i in range(hp["depth"]):
            shapes[f"trunk.{i}.weight"] = (width, n_in)
            shapes[f"trunk.{i}.bias"] = (width,)
            n_in = width
        shapes["coeff.weight"] = (hp["modes"], n_in)
        shapes["coeff.bias"] = (hp["modes"],)
        shapes["basis.weight"] = (2 * hp["size"] ** 2, hp["modes"])
        shapes["basis.bias"] = (2 * hp["size"] ** 2,)
        return shapes

    def features(self, scans, w_up, w_robot, g=None) -> dict:
        """``g`` (B,), ``channels`` (B, 2, n_rays / pool), ``winds`` (B, 5), ``scale`` (B,) m/s,
        ``w_robot`` (B, 2) m/s canonical, ``w_robot_world`` (B, 2) m/s. ``g``: the D4 elements
        to take the inputs into the model frame by (default :func:`canonical_elements` of
        ``w_up``; another puts the inlet outside [0, 45] deg, as ``boundary="blend"`` does)."""
        hp = self.hp
        g, up, scale = self._upstream(w_up, g)
        # centred_min_pool, then the sectors into the canonical frame: one gather of each
        # canonical sector's rays (the same minimum of the same ranges)
        b, n_rays = scans.shape
        rays = self._sector_rays[g]
        rays += (np.arange(b) * n_rays)[:, None]
        pooled = _run_min(np.ascontiguousarray(scans).ravel().take(rays), hp["pool"])
        w_robot_c = np.einsum("bij,bj->bi", _D4[g], w_robot).astype(np.float32)
        return {"g": g, "channels": range_channels(pooled, hp["range_scale"], hp["range_min"]),
                "winds": robot_features(up, w_robot_c, scale), "scale": scale,
                "w_robot": w_robot_c, "w_robot_world": np.asarray(w_robot, dtype=np.float32)}

    def _upstream(self, w_up, g=None):
        """``g``, ``W_up / U`` and ``U`` of a batch of inlet winds (fresh arrays), ``g`` the
        given D4 elements or :func:`canonical_elements`. The last batch's of the latter are
        kept: a flight asks with the same inlet wind at every prediction."""
        w_up = np.asarray(w_up)
        if g is not None:  # another frame (boundary="blend"'s second passes): not kept
            g = np.asarray(g, dtype=np.int64)
            return (g, *upstream_features(np.einsum("bij,bj->bi", _D4[g], w_up),
                                          self.hp["speed_floor"]))
        key = (w_up.shape, w_up.dtype.str, w_up.tobytes())
        if self._upstream_memo is None or self._upstream_memo[0] != key:
            self._upstream_memo = (key, *self._upstream(w_up, canonical_elements(w_up)))
        return tuple(a.copy() for a in self._upstream_memo[1:])

    def coefficients(self, w: dict, f: dict) -> np.ndarray:
        """The mode coefficients ``(B, modes)``, in units of U; ``w`` as :meth:`prepare`
        returns it."""
        channels, winds = f["channels"], f["winds"]
        b = channels.shape[0]
        # circular convolution, banded: each block of output sectors is one product of its
        # window of input sectors with the same block matrix (_prepare_member), columns
        # ordered (parity, position / 2, channel), so the max-pool of 2 is the larger of two
        # halves; the ReLU comes after the pool (they commute). One sample (the onboard
        # stack's call) keeps the dense circulant product, as cheap for one row: the
        # benchmark's recorded flights replay only with the arithmetic that flew them
        if b == 1:
            y = channels.reshape(1, -1) @ w["conv.circulant"] + w["conv.bias_circulant"]
        else:
            windows = channels.reshape(b, -1).take(self._conv_windows, axis=1)
            y = windows.reshape(-1, w["conv.block"].shape[0]) @ w["conv.block"] \
                + w["conv.bias_cols"]
        half = y.shape[1] // 2
        y = np.maximum(y[:, :half], y[:, half:]).reshape(b, -1)
        np.maximum(y, 0.0, out=y)
        e = y @ w["embed.weight"].T + w["embed.bias"]
        hidden = np.maximum(winds @ w["film_in.weight"].T + w["film_in.bias"], 0.0)
        gb = hidden @ w["film_out.weight"].T + w["film_out.bias"]
        n_e = e.shape[1]
        h = np.maximum(e * (1.0 + gb[:, :n_e]) + gb[:, n_e:], 0.0)
        h = np.concatenate([h, winds], axis=1)
        for i in range(self.hp["depth"]):
            h = h @ w[f"trunk.{i}.weight"].T + w[f"trunk.{i}.bias"]
            np.maximum(h, 0.0, out=h)
        return h @ w["coeff.weight"].T + w["coeff.bias"]

    def network(self, w: dict, f: dict) -> np.ndarray:
        """Canonical field ``(B, 2, H^2)``, m/s: ``w_robot + U (coefficients @ basis)``; the
        mean of the members' fields when there are several."""
        if "members" in w:
            return np.mean([self.network(m, f) for m in w["members"]], axis=0)
        a = self.coefficients(w, f)
        r = (a @ w["basis.weight"].T + w["basis.bias"]).reshape(a.shape[0], 2, -1)
        r *= f["scale"][:, None, None]
        r += f["w_robot"][:, :, None]
        return r

    def world_frame(self, field_c: np.ndarray, f: dict) -> np.ndarray:
        h = self.hp["size"]
        return uncanonicalize(field_c, f["g"]).reshape(-1, 2, h, h)

    def model_labels(self, labels: np.ndarray, free: np.ndarray, f: dict):
        return canonicalize_field(labels, f["g"]), permute_cells(free, self._inverse, f["g"])

    def prepare(self, w: dict) -> dict:
        """The weights plus what inference derives from them once.

        With ``members`` M > 1: ``members`` (each member's prepared weights, as below) and one
        ``basis.folded`` ``(8, M modes + 3, 2 H^2)`` that holds every member's modes divided
        by M, then the mean of their bias rows and the uniform rows: the mean of the members'
        fields in one product (the decoder is linear in its mode coefficients).

        ``conv.block (2 (P + K - 1), P C)`` and ``conv.bias_cols (P C,)``: the circular
        convolution (kernel ``K``) over a block of ``P`` sectors (:func:`conv_block`) as a
        matrix on its window of ``P + K - 1`` sectors of both channels, output columns ordered
        (parity, position / 2, channel); the same matrix for every block.
        ``conv.circulant (2 N, N C)`` and ``conv.bias_circulant (N C,)``: the same convolution
        over all ``N`` sectors as one dense matrix, for a single sample (its arithmetic is
        that of the flights recorded before the banded form, which replay only with it).
        ``basis.folded (8, modes + 3, 2 H^2)``: for each element ``g``, the basis, its bias and
        the two uniform unit fields, with the way back to the world frame folded in (cells
        permuted, components multiplied by ``A_g^T``), so that the world field is
        ``[U a, U, W_robot] @ basis.folded[g]``.
        """
        m = self.hp["members"]
        if m > 1:
            parts = [self._prepare_member(member_weights(w, i)) for i in range(m)]
            k = self.hp["modes"]
            folded = [p.pop("basis.folded") for p in parts]
            shared = sum(f[:, k:] for f in folded) / np.float32(m)
            return {"members": parts, "basis.folded": np.concatenate(
                [f[:, :k] / np.float32(m) for f in folded] + [shared], axis=1)}
        return self._prepare_member(w)

    def _prepare_member(self, w: dict) -> dict:
        hp = self.hp
        conv = w["conv.weight"]
        c_out, c_in, k = conv.shape
        p = self._block
        block = np.zeros((c_in, p + k - 1, 2, p // 2, c_out), dtype=np.float32)
        for pos in range(p):
            block[:, pos:pos + k, pos % 2, pos // 2, :] = conv.transpose(1, 2, 0)
        n, pad = hp["n_rays"] // hp["pool"], k // 2
        circulant = np.zeros((c_in, n, 2, n // 2, c_out), dtype=np.float32)
        for pos in range(n):
            for t in range(k):
                circulant[:, (pos + t - pad) % n, pos % 2, pos // 2, :] += conv[:, :, t].T
        cells = hp["size"] ** 2
        basis = w["basis.weight"].T.reshape(hp["modes"], 2, cells)
        bias = w["basis.bias"].reshape(1, 2, cells)
        folded = np.empty((8, hp["modes"], 2 * cells), dtype=np.float32)
        folded_bias = np.empty((8, 2 * cells), dtype=np.float32)
        for g in range(8):
            perm = self._perm[g]
            folded[g] = np.einsum("ij,kjn->kin", _D4_T[g], basis[:, :, perm]).reshape(
                hp["modes"], -1)
            folded_bias[g] = np.einsum("ij,kjn->kin", _D4_T[g], bias[:, :, perm]).reshape(-1)
        # rows for the uniform W_robot: 1 on the u (then v) cells
        uniform = np.zeros((8, 2, 2 * cells), dtype=np.float32)
        uniform[:, 0, :cells] = uniform[:, 1, cells:] = 1.0
        return {**w, "conv.block": block.reshape(c_in * (p + k - 1), p * c_out),
                "conv.bias_cols": np.tile(w["conv.bias"], p),
                "conv.circulant": circulant.reshape(c_in * n, n * c_out),
                "conv.bias_circulant": np.tile(w["conv.bias"], n),
                "basis.folded": np.concatenate([folded, folded_bias[:, None], uniform], axis=1)}

    def augmented(self, w: dict, scans, w_up, w_robot, g=None) -> tuple:
        """``(aug, g)``: each sample's row ``[U a, U, W_robot]`` (B, members x modes + 3),
        float32, whose product with ``basis.folded[g]`` is its world field (scale, bias and
        residual in one product: :meth:`expand`), and its D4 element ``g`` (B,) (the given
        ones, or :func:`canonical_elements` of ``w_up``). The field is linear in the row, so a
        blend of two fields is the sum of the products of the rows weighted."""
        f = self.features(scans, w_up, w_robot, g)
        a = (np.concatenate([self.coefficients(m, f) for m in w["members"]], axis=1)
             if "members" in w else self.coefficients(w, f))
        b, k = a.shape
        aug = np.empty((b, k + 3), dtype=np.float32)
        np.multiply(a, f["scale"][:, None], out=aug[:, :k])
        aug[:, k] = f["scale"]
        aug[:, k + 1:] = f["w_robot_world"]
        return aug, f["g"]

    @staticmethod
    def expand(w: dict, aug, g, out=None, rows=None) -> np.ndarray:
        """The world fields ``aug @ basis.folded[g]`` row by row, ``(B, 2 H^2)`` float32, m/s,
        ``[u cells, v cells]``: written to a new array, or with ``out``, added into
        ``out[rows]`` (``rows``: distinct rows of ``out``, one per row of ``aug``; default its
        first rows). The rows are
        grouped by element, :data:`PREDICT_CHUNK` per product, so each element's basis is read
        once per group and the temporaries stay a chunk's; a batch of one element (one inlet's,
        or one sample: the onboard stack's) is one product."""
        basis = w["basis.folded"]
        add = out is not None
        if not add:
            out = np.empty((aug.shape[0], basis.shape[2]), dtype=np.float32)
            if not g.size or (g == g[0]).all():
                return np.matmul(aug, basis[g[0] if g.size else 0], out=out)
        order = np.argsort(g, kind="stable")
        bounds = np.searchsorted(g[order], np.arange(9))
        for e in range(8):
            for lo in range(bounds[e], bounds[e + 1], PREDICT_CHUNK):
                group = order[lo:min(lo + PREDICT_CHUNK, bounds[e + 1])]
                part = aug[group] @ basis[e]
                dest = group if rows is None else rows[group]
                if add:
                    out[dest] += part
                else:
                    out[dest] = part
        return out

    def predict(self, w: dict, scans, w_up, w_robot, g=None) -> np.ndarray:
        aug, g = self.augmented(w, scans, w_up, w_robot, g)
        return self.expand(w, aug, g).reshape(aug.shape[0], 2, -1)


ARCHITECTURES = {a.name: a for a in (ThesisMLPArchitecture, D4FilmArchitecture)}
"""Architecture name -> its class (see :class:`ThesisMLPArchitecture` for the parts)."""

WIND_INPUTS = ("both", "up", "robot", "none")
"""The ``winds`` hyperparameter of ``thesis-mlp``: the winds given to the network (``up``:
``W_up`` only, ``robot``: ``W_robot`` only); the others are inputs held at 0 (the ablation)."""

_INT_HP = ("n_rays", "width", "depth", "pool", "conv_channels", "kernel", "embed",
           "film_hidden", "modes", "size", "members")


def make_architecture(name: str, size: int, **overrides):
    """An architecture with complete, checked hyperparameters for an ``size x size`` grid.

    Parameters
    ----------
    name : {"thesis-mlp", "d4-film"}
    size : int
        H, cells per side of the output grid.
    **overrides
        Hyperparameters replacing the architecture's ``defaults``.

    Returns
    -------
    ThesisMLPArchitecture or D4FilmArchitecture
        Its ``hp`` holds every hyperparameter, ``size`` included.
    """
    where = "make_architecture"
    if name not in ARCHITECTURES:
        raise ValueError(f"The 'name' parameter of {where} must be one of "
                         f"{sorted(ARCHITECTURES)}. Got {name!r} instead.")
    cls = ARCHITECTURES[name]
    unknown = sorted(set(overrides) - set(cls.defaults))
    if unknown:
        raise ValueError(f"The hyperparameters of {where} for {name!r} must be among "
                         f"{sorted(cls.defaults)}. Got unknown {unknown} instead.")
    hp = {**cls.defaults, **overrides, "size": size}
    for key in _INT_HP:
        v = hp.get(key, 1)
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer)) or int(v) != v \
                or v < 1:
            raise ValueError(f"The '{key}' hyperparameter of {where} must be an integer >= 1. "
                             f"Got {v!r} instead.")
        if key in hp:
            hp[key] = int(v)
    for key in ("range_scale", "range_min", "speed_floor", "wind_scale"):
        if key in hp and not (isinstance(hp[key], (int, float)) and 0 < hp[key] < math.inf):
            raise ValueError(f"The '{key}' hyperparameter of {where} must be a positive "
                             f"number. Got {hp[key]!r} instead.")
        if key in hp:
            hp[key] = float(hp[key])
    if "winds" in hp and hp["winds"] not in WIND_INPUTS:
        raise ValueError(f"The 'winds' hyperparameter of {where} must be one of {WIND_INPUTS}. "
                         f"Got {hp['winds']!r} instead.")
    if name == "d4-film":
        p, n = hp["pool"], hp["n_rays"]
        if p % 2 == 0 or n % p or (n // p) % 4:
            raise ValueError(f"The 'pool' hyperparameter of {where} must be odd and divide "
                             f"n_rays = {n} into a multiple of 4 sectors (3, 5, 9, ... for "
                             f"360). Got {p!r} instead.")
        if hp["kernel"] % 2 == 0:
            raise ValueError(f"The 'kernel' hyperparameter of {where} must be odd. Got "
                             f"{hp['kernel']!r} instead.")
    return cls(hp)


def member_weights(weights: dict, i: int) -> dict:
    """Member ``i``'s parameters (those named ``member{i}.<name>``), under their own names."""
    prefix = f"member{i}."
    return {k[len(prefix):]: v for k, v in weights.items() if k.startswith(prefix)}


def ensemble_decoder(decoders, metadata: dict | None = None) -> Decoder:
    """One decoder whose prediction is the mean of the given ``d4-film`` decoders' (its
    ``members``), evaluated as one forward pass (:meth:`D4FilmArchitecture.prepare`).

    Parameters
    ----------
    decoders : sequence of Decoder
        At least two single-member ``d4-film`` decoders with the same hyperparameters and grid
        spacing (members trained from different seeds, ``train.members`` of a recipe).
    metadata : dict, optional
        The ensemble's metadata; default the first member's. ``architecture``,
        ``hyperparameters`` (with ``members``) and ``spacing`` are set here.

    Returns
    -------
    Decoder
    """
    where = "ensemble_decoder"
    decoders = list(decoders)
    if len(decoders) < 2:
        raise ValueError(f"The 'decoders' parameter of {where} must hold at least 2 decoders. "
                         f"Got {len(decoders)} instead.")
    first = decoders[0]
    for i, d in enumerate(decoders):
        if not isinstance(d, Decoder) or d.architecture != "d4-film" \
                or d.hyperparameters != first.hyperparameters or d.spacing != first.spacing \
                or d.hyperparameters["members"] != 1:
            raise ValueError(
                f"The 'decoders' parameter of {where} must hold single-member d4-film decoders "
                f"with the same hyperparameters and spacing. Got {d!r} at {i} instead "
                f"(the first: {first!r}).")
    weights = {f"member{i}.{k}": v for i, d in enumerate(decoders) for k, v in d.weights.items()}
    hp = {**first.hyperparameters, "members": len(decoders)}
    meta = {**(first.metadata if metadata is None else metadata), "architecture": "d4-film",
            "hyperparameters": hp, "spacing": first.spacing}
    return Decoder(weights, meta)


# --------------------------------------------------------------------------- Decoder


class Decoder(ReadOnlyOnCopy):
    """A trained wind flow decoder, evaluated with NumPy.

    Parameters
    ----------
    weights : dict of str to ndarray
        The parameters, named as in ``make_architecture(...).shapes()`` (copied as float32;
        :attr:`weights` holds the copies, read-only: build a new ``Decoder`` to change them).
    metadata : dict
        At least ``architecture``, ``hyperparameters`` (with ``size``) and ``spacing`` (m).
    boundary : {"average", "floor", "blend"}
        A free-stream direction on a sector boundary of the d4-film's frame (a multiple of 45
        deg): the mean of the two sides, or the side rounding picks; ``"blend"`` also blends
        the two sides' answers within :data:`BLEND_WIDTH_DEG` of one, so that the field is
        continuous in the inlet direction (:data:`BOUNDARIES`). The default here is the one
        pass off the boundaries (``"average"``): a ``Decoder`` built from weights is the
        network as trained (training validates it so, and it matches the torch module);
        :func:`load_decoder`, the entry point for a model file, blends by default since
        2026-12-06.
    rotations_deg : sequence of float, optional
        Predict the mean over views of the scene turned by each of these angles, deg
        counter-clockwise (whole rays, within :data:`ROTATIONS_LIMIT_DEG` of 0; 0 is the
        scene as given): each view's scan is shifted by its angle, its winds turned, and its
        field turned back onto the world-aligned grid by bilinear interpolation
        (:func:`turn_field_back`). A test-time ensemble of one model: ``(0, -3, 3)`` took the
        windinet speed error of the model of 2026-12-01 from 0.618 to 0.601 m/s at 3.5 x the
        time, and that of the model of 2026-12-06 from 0.6175 to 0.6006 (docs/decoder.md,
        "Turned views"). Default: the scene as given, one pass.

    Attributes
    ----------
    offsets : ndarray of shape (H,)
        Cell-centre offsets of the output grid, m, the same for x and y.
    size : int
        H, cells per side.
    spacing : float
        Cell size, m.
    architecture : str
        Its name.
    arch : ThesisMLPArchitecture or D4FilmArchitecture
        The architecture's parts (features, network, frame changes).
    hyperparameters : dict
    metadata : dict
        Everything the file holds besides the weights (recipe, metrics, ...).
    n_parameters : int
    rotations_deg : tuple of float or None
        The views averaged (None: one pass on the scene as given).

    Raises
    ------
    ValueError
        Naming the parameter: bad ``metadata`` or ``weights``, a ``boundary`` not in
        :data:`BOUNDARIES`, or ``rotations_deg`` not a flat sequence of whole-ray angles within
        :data:`ROTATIONS_LIMIT_DEG` of 0 (:func:`check_rotations`).
    """

    def __init__(self, weights: dict, metadata: dict, *, boundary: str = "average",
                 rotations_deg=None):
        where = "Decoder"
        self.boundary = _check_boundary(boundary, where)
        name = metadata.get("architecture")
        if name not in ARCHITECTURES:
            raise ValueError(f"The 'metadata' parameter of {where} must name an architecture "
                             f"among {sorted(ARCHITECTURES)}. Got {name!r} instead.")
        hp = dict(metadata.get("hyperparameters", {}))
        arch = make_architecture(name, hp.pop("size", metadata.get("size")), **hp)
        shapes = arch.shapes()
        missing = sorted(set(shapes) - set(weights))
        extra = sorted(set(weights) - set(shapes))
        bad = [(k, tuple(np.shape(weights[k])), shapes[k]) for k in sorted(shapes)
               if k in weights and tuple(np.shape(weights[k])) != tuple(shapes[k])]
        if missing or extra or bad:
            raise ValueError(
                f"The 'weights' parameter of {where} must hold the parameters of {name!r} with "
                f"size {arch.hp['size']}. Got missing {missing}, unexpected {extra}, wrong "
                f"shapes {bad} instead.")
        # the decoder's own read-only copies: the caller's arrays may change afterwards, and
        # an edit of these would reach some layers and not those prepared below
        self.weights = {k: np.array(weights[k], dtype=np.float32, order="C") for k in shapes}
        for k, v in self.weights.items():
            if not np.all(np.isfinite(v)):
                raise ValueError(f"The 'weights' parameter of {where} must be finite. Got "
                                 f"non-finite values in {k!r} instead.")
            v.setflags(write=False)
        self.architecture = name
        self.arch = arch
        self.hyperparameters = arch.hp
        self.size = arch.hp["size"]
        self.spacing = float(metadata.get("spacing", 1.0))
        self.n_rays = arch.hp["n_rays"]
        self.rotations_deg = check_rotations(rotations_deg, self.n_rays, where)
        self.offsets = grid_offsets(self.size, self.spacing)
        self.offsets.setflags(write=False)  # the onboard stack places its field by them
        self._resamplers = {a: rotation_resampler(self.offsets, a)
                            for a in (self.rotations_deg or ()) if a != 0.0}
        self.metadata = {**metadata, "architecture": name, "hyperparameters": dict(arch.hp),
                         "size": self.size, "spacing": self.spacing, "n_rays": self.n_rays}
        self.prepared = arch.prepare(self.weights)
        # a view's field is linear in the d4-film's folded basis, so turning it back is folded
        # into that basis once (exactly: the same products as turning each field back)
        self._turned = {a: {**self.prepared, "basis.folded": turn_field_back(
            self.prepared["basis.folded"].reshape(-1, 2, self.size, self.size), p, a
        ).reshape(self.prepared["basis.folded"].shape)}
            for a, p in self._resamplers.items() if "basis.folded" in self.prepared}

    @property
    def n_parameters(self) -> int:
        """Number of scalar parameters."""
        return int(sum(v.size for v in self.weights.values()))

    def predict(self, scans, w_up, w_robot) -> np.ndarray:
        """The local mean wind field around each robot.

        Parameters
        ----------
        scans : array_like of shape (B, n_rays)
            LiDAR ranges, m; ray ``k`` at ``360 k / n_rays`` deg counter-clockwise from +x
            (world frame), as :meth:`windnav.city.City.lidar` returns them.
        w_up : array_like of shape (B, 2) or (2,)
            Free-stream (inlet) wind, world frame, m/s (``(2,)``: the same for every scan;
            e.g. ``FlowSolution.inlet_xy``).
        w_robot : array_like of shape (B, 2) or (2,)
            Time-averaged wind at the robot, world frame, m/s (``(2,)``: the same for every
            scan).

        Returns
        -------
        ndarray of shape (B, 2, H, H), float32
            ``[u, v]`` in m/s, world frame, indexed ``[.., iy, ix]`` at
            ``(x + offsets[ix], y + offsets[iy])``.

        Raises
        ------
        ValueError
            Naming the argument, for a scan of the wrong length, NaN or negative ranges, NaN
            wind or a batch-size mismatch (:func:`windnav.predict.baselines.check_inputs`).

        Warns
        -----
        RuntimeWarning
            For scans that read 0 m on every ray (a robot on or inside a building), and for
            scans whose largest range, under the model's ``range_scale`` (100 m), is read by
            :data:`SHORT_RANGE_TIES` rays or more (a LiDAR whose misses read a shorter
            maximum range, which the decoder would read as walls: give a miss 100 m or more).

        A ``w_up`` whose direction is a multiple of 45 deg is answered as :attr:`boundary`
        says (:data:`BOUNDARIES`): under ``"average"`` and ``"blend"`` the mean of the two
        sides, two forward passes for those samples; under ``"blend"`` (:func:`load_decoder`'s
        default) also every sample within :data:`BLEND_WIDTH_DEG` of one takes a second pass
        (12.9 against 8.9 ms per 1,024 random inlets on one thread). With
        :attr:`rotations_deg` the answer is the mean over those views (a pass each, under the
        same rule).
        """
        scans, w_up, w_robot = check_inputs(scans, w_up, w_robot, "Decoder.predict")
        if scans.shape[1] != self.n_rays:
            raise ValueError(f"The 'scans' parameter of Decoder.predict must have "
                             f"{self.n_rays} rays per scan. Got shape {scans.shape} instead.")
        # on or inside a building City.lidar reads 0 m on every ray, or its min_range where
        # the scan is clipped to one (the onboard stack's and the datasets' 0.25 m)
        top = scans.max(axis=1)
        least = self.hyperparameters.get("range_min", SCAN_MIN)  # the samples' clip
        inside = top <= least
        if inside.any():  # a field for a robot in a wall, unflagged until the API audit
            warnings.warn(f"Decoder.predict: {int(inside.sum())} of {scans.shape[0]} scans read "
                          f"0 m on every ray, or no more than the {least:g} m least range "
                          f"(first: row {int(np.flatnonzero(inside)[0])}), City.lidar's "
                          "reading on or inside a building; the decoder was trained on robots "
                          "1-40 m from buildings, so those fields mean nothing.",
                          RuntimeWarning, stacklevel=2)
        self._warn_short_range(scans, top, least)
        if self.rotations_deg is None:
            if self.boundary == "blend":  # its second passes gather rows: converted once
                scans = scans.astype(np.float32)
            return self._sides(scans, w_up, w_robot)
        out = np.zeros((scans.shape[0], 2, self.size, self.size), dtype=np.float32)
        scans = scans.astype(np.float32)  # as each pass takes them, converted once for all
        for angle in self.rotations_deg:
            if angle == 0.0:
                out += self._sides(scans, w_up, w_robot)
            elif angle in self._turned:  # the d4-film: turned back within its basis
                out += self._sides(*turned_inputs(scans, w_up, w_robot, angle),
                                   self._turned[angle])
            else:
                out += turn_field_back(self._sides(*turned_inputs(scans, w_up, w_robot, angle)),
                                       self._resamplers[angle], angle)
        out /= np.float32(len(self.rotations_deg))
        return out

    def _warn_short_range(self, scans: np.ndarray, top: np.ndarray, least: float) -> None:
        """A RuntimeWarning for scans whose largest range ``top``, under the model's
        ``range_scale`` (100 m) and above its least range ``least`` (a scan inside a
        building, warned as such), is read by :data:`SHORT_RANGE_TIES` rays or more: the
        signature of a LiDAR whose misses read its own, shorter maximum range, which the
        decoder reads as walls there (it was trained on misses at ``range_scale``)."""
        full = np.float32(self.hyperparameters["range_scale"])
        candidates = (top < full) & (top > least)
        if not candidates.any():  # every scan reaches the model's range: the common case
            return
        # counted over the whole batch: a boolean temporary, not a copy of the rows' ranges
        ties = np.count_nonzero(scans == top[:, None], axis=1)
        short = np.flatnonzero(candidates & (ties >= SHORT_RANGE_TIES))
        if short.size:
            first = int(short[0])
            warnings.warn(f"Decoder.predict: {short.size} of {scans.shape[0]} scans have "
                          f"{SHORT_RANGE_TIES} or more rays at exactly their largest range, "
                          f"under the decoder's {float(full):g} m (first: row {first}, "
                          f"{int(ties[first])} rays at "
                          f"{float(top[first]):g} m): a LiDAR whose misses read a shorter "
                          "maximum range? The decoder reads them as walls at that range; it "
                          f"was trained with misses at {float(full):g} m, so give a miss "
                          f"{float(full):g} m or more.", RuntimeWarning, stacklevel=3)

    def _sides(self, scans, w_up, w_robot, prepared=None) -> np.ndarray:
        """The network's field for checked inputs, a boundary's two sides averaged as
        :attr:`boundary` says (and blended near one for ``"blend"``); ``prepared``: other
        prepared weights (a turned view's)."""
        d4 = isinstance(self.arch, D4FilmArchitecture)
        on = (on_sector_boundary(w_up)
              if self.boundary in ("average", "blend") and d4 else None)
        if on is not None and on.any():  # the mean of the two sides: the symmetry holds too
            out = np.empty((scans.shape[0], 2, self.size, self.size), dtype=np.float32)
            off = np.flatnonzero(~on)
            if off.size:
                out[off] = self._sides(scans[off], w_up[off], w_robot[off], prepared)
            rows = np.flatnonzero(on)
            sides = [self._predict(scans[rows], boundary_side(w_up[rows], sign), w_robot[rows],
                                   prepared) for sign in (1.0, -1.0)]
            out[rows] = 0.5 * (sides[0] + sides[1])
            return out
        if self.boundary == "blend" and d4:
            near = self._blend_rows(w_up)
            if near[0].size:
                return self._blended(scans, w_up, w_robot, prepared, *near)
        return self._predict(scans, w_up, w_robot, prepared)

    @staticmethod
    def _blend_rows(w_up):
        """``boundary="blend"``'s rows of inlets off every boundary (:meth:`_sides` answers
        those on one): those within :data:`BLEND_WIDTH_DEG` of a sector boundary, the D4
        elements of the boundary's other side for them, and their weights
        ``(1 - |s| / BLEND_WIDTH_DEG) / 2``, ``s`` the distance from the boundary, deg."""
        w = np.asarray(w_up, dtype=np.float64)
        alpha = np.degrees(np.arctan2(w[:, 1], w[:, 0]))
        s = _boundary_offset_deg(alpha)  # signed distance from the nearest boundary, deg
        rows = np.flatnonzero((np.abs(s) < BLEND_WIDTH_DEG) & (np.hypot(w[:, 0], w[:, 1]) > 0))
        mirrored = np.radians(alpha[rows] - 2.0 * s[rows])  # as far on the other side
        g_other = canonical_elements(np.column_stack([np.cos(mirrored), np.sin(mirrored)]))
        weight = (0.5 * (1.0 - np.abs(s[rows]) / BLEND_WIDTH_DEG)).astype(np.float32)
        return rows, g_other, weight

    def _blended(self, scans, w_up, w_robot, prepared, rows, g_other, weight) -> np.ndarray:
        """The network's field for inlets off every boundary, ``rows`` (distinct) blended with
        its answer through ``g_other``: ``(1 - weight)`` times the first pass plus ``weight``
        times the second, taken on the augmented rows (the field is linear in them,
        :meth:`D4FilmArchitecture.augmented`), so a second pass adds its grouped product into
        the output rows instead of a field of its own blended with theirs (docs/decoder.md,
        "Speed")."""
        prepared = self.prepared if prepared is None else prepared
        b, h = scans.shape[0], self.size
        aug, g = self._augmented(scans, w_up, w_robot, prepared)
        aug_other, g_other = self._augmented(scans, w_up, w_robot, prepared, rows, g_other)
        aug[rows] *= (1.0 - weight)[:, None]
        aug_other *= weight[:, None]
        out = self.arch.expand(prepared, aug, g)
        self.arch.expand(prepared, aug_other, g_other, out=out, rows=rows)
        return out.reshape(b, 2, h, h)

    def _augmented(self, scans, w_up, w_robot, prepared, rows=None, g=None) -> tuple:
        """:meth:`D4FilmArchitecture.augmented` of the batch's ``rows`` (default all), chunk by
        chunk of :data:`PREDICT_CHUNK` (each chunk's rows gathered and made float32 in turn;
        ``g``: the D4 elements to take, one per row, as there)."""
        n = scans.shape[0] if rows is None else rows.size
        # a row per sample as wide as the folded basis it multiplies (members x modes + 3)
        aug = np.empty((n, prepared["basis.folded"].shape[1]), dtype=np.float32)
        elements = np.empty(n, dtype=np.int64)
        for i in range(0, n, PREDICT_CHUNK):
            j = min(n, i + PREDICT_CHUNK)
            take = slice(i, j) if rows is None else rows[i:j]
            aug[i:j], elements[i:j] = self.arch.augmented(
                prepared, *(np.asarray(a[take], dtype=np.float32) for a in (scans, w_up, w_robot)),
                None if g is None else g[i:j])
        return aug, elements

    def _predict(self, scans, w_up, w_robot, prepared=None) -> np.ndarray:
        """The network's field for checked inputs, in chunks of :data:`PREDICT_CHUNK`, with
        :attr:`prepared` or the ``prepared`` weights given; for the d4-film the mode
        coefficients by chunks, then the fields of the whole batch grouped by D4 element
        (:meth:`D4FilmArchitecture.expand`: each element's basis read once per group, not
        once per chunk)."""
        prepared = self.prepared if prepared is None else prepared
        b, h = scans.shape[0], self.size
        if isinstance(self.arch, D4FilmArchitecture):
            aug, g = self._augmented(scans, w_up, w_robot, prepared)
            return self.arch.expand(prepared, aug, g).reshape(b, 2, h, h)
        out = np.empty((b, 2, h, h), dtype=np.float32)
        for i in range(0, b, PREDICT_CHUNK):
            j = min(b, i + PREDICT_CHUNK)
            out[i:j] = self.arch.predict(prepared,
                                         np.asarray(scans[i:j], dtype=np.float32),
                                         np.asarray(w_up[i:j], dtype=np.float32),
                                         np.asarray(w_robot[i:j], dtype=np.float32)
                                         ).reshape(j - i, 2, h, h)
        return out

    def save(self, path) -> Path:
        """Write this decoder to ``path`` (.npz); see :func:`save_decoder`."""
        return save_decoder(self.weights, self.metadata, path)

    def fingerprint(self) -> str:
        """SHA-256 (hex) of what the predictions depend on: the weights (by name, float32
        bytes), the architecture, its hyperparameters, the spacing, the boundary rule and the
        views (:attr:`rotations_deg`, when set). Two
        decoders of one architecture and size print alike; this tells them apart."""
        import hashlib

        h = hashlib.sha256()
        # the views only when set: a decoder without them prints as before they existed
        views = {} if self.rotations_deg is None else {"rotations_deg": self.rotations_deg}
        h.update(json.dumps({"architecture": self.architecture,
                             "hyperparameters": self.hyperparameters,
                             "spacing": self.spacing, "boundary": self.boundary, **views},
                            sort_keys=True, default=str).encode())
        for name in sorted(self.weights):
            w = self.weights[name]
            h.update(f"{name}{w.shape}".encode())
            h.update(np.ascontiguousarray(w, dtype=np.float32).tobytes())
        return h.hexdigest()

    def __repr__(self) -> str:
        views = "" if self.rotations_deg is None else (
            f", rotations_deg=({', '.join(f'{a:g}' for a in self.rotations_deg)}) deg")
        return (f"Decoder({self.architecture!r}, H={self.size}, spacing={self.spacing:g} m, "
                f"{self.n_parameters} parameters{views})")


def save_decoder(weights: dict, metadata: dict, path) -> Path:
    """Write a decoder file: the parameters and the JSON metadata in one ``.npz``.

    The file is written to a temporary name and renamed, so a crash never leaves a half
    file under ``path``. ``format`` and ``version`` are set here.

    Returns
    -------
    Path
        The file written.
    """
    path = Path(path)
    meta = {**metadata, "format": FORMAT, "version": FORMAT_VERSION}
    arrays = {k: np.asarray(v, dtype=np.float32) for k, v in weights.items()}
    if METADATA_KEY in arrays:
        raise ValueError(f"The 'weights' parameter of save_decoder must not hold a parameter "
                         f"named {METADATA_KEY!r}.")
    arrays[METADATA_KEY] = np.array(json.dumps(meta, sort_keys=True, default=_jsonable))
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp.npz")
    np.savez(tmp, **arrays)
    os.replace(tmp, path)
    return path


def _jsonable(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def load_decoder(path=None, *, boundary: str = "blend", rotations_deg=None) -> Decoder:
    """Load a wind flow decoder.

    Parameters
    ----------
    path : str or path-like, optional
        A decoder file (.npz) written by :func:`save_decoder` or ``windnav train-decoder``.
        Default: the model shipped with windnav (``windnav/predict/data/decoder_default.npz``).
    boundary : {"blend", "average", "floor"}
        Free-stream directions on (and for ``"blend"``, the default, within
        :data:`BLEND_WIDTH_DEG` of) a multiple of 45 deg (:data:`BOUNDARIES`). ``"average"``
        is one pass off the boundaries, the rule of every result made before 2026-12-06's
        forty-fifth session. The rule is not stored in the file: a :class:`Decoder` saved
        and loaded back answers with the rule it is loaded with.
    rotations_deg : sequence of float, optional
        Average the prediction over the scene turned by these angles, deg (:class:`Decoder`).

    Returns
    -------
    Decoder

    Raises
    ------
    ValueError
        Naming 'path', when the file is missing, is not a decoder file, is corrupt, or was
        written by an incompatible format version; naming 'boundary' or 'rotations_deg' for a
        value :class:`Decoder` refuses.
    """
    where = "load_decoder"
    _check_boundary(boundary, where)  # before the file is read
    check_rotations(rotations_deg, N_RAYS, where)  # the scans' rays (every shipped model's)
    if path is None:
        if not DEFAULT_MODEL.is_file():
            raise ValueError(
                f"The 'path' parameter of {where} defaults to the shipped decoder "
                f"{str(DEFAULT_MODEL)!r}, which is not installed. Build it with `windnav "
                f"train-decoder --config {DEFAULT_RECIPE}` and copy its model.npz there, or "
                "pass the path of a trained decoder."
            )
        path = DEFAULT_MODEL
    path = Path(path)
    if not path.is_file():
        what = "a folder" if path.is_dir() else "which does not exist"
        raise ValueError(f"The 'path' parameter of {where} must name an existing decoder file "
                         f"(.npz). Got {str(path)!r} instead, {what}.")
    if not zipfile.is_zipfile(path):  # NumPy would read it as a pickle and suggest allow_pickle
        raise ValueError(f"The 'path' parameter of {where} must name a readable decoder file "
                         f"(.npz). Got {str(path)!r} instead, which is not an .npz (zip) "
                         "archive.")
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {k: np.asarray(data[k]) for k in data.files}
    except Exception as exc:  # zip, header and decompression errors all mean a corrupt file
        raise ValueError(f"The 'path' parameter of {where} must name a readable decoder file "
                         f"(.npz). Got {str(path)!r} instead, which cannot be read: "
                         f"{type(exc).__name__}: {exc}") from exc
    raw = arrays.pop(METADATA_KEY, None)
    try:
        meta = json.loads(str(raw[()])) if raw is not None else None
    except (ValueError, TypeError, IndexError) as exc:
        raise ValueError(f"The 'path' parameter of {where} names {str(path)!r}, whose metadata "
                         f"is not valid JSON: {exc}") from exc
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise ValueError(f"The 'path' parameter of {where} must name a windnav decoder file. "
                         f"Got {str(path)!r} instead, which has no '{FORMAT}' metadata.")
    version = meta.get("version")
    if version != FORMAT_VERSION:
        raise ValueError(f"The 'path' parameter of {where} names {str(path)!r}, a decoder file "
                         f"of format version {version!r}; this windnav reads version "
                         f"{FORMAT_VERSION}. Retrain it with `windnav train-decoder`.")
    try:
        return Decoder(arrays, meta, boundary=boundary, rotations_deg=rotations_deg)
    except (ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"The 'path' parameter of {where} names {str(path)!r}, whose "
                         f"parameters do not match its metadata: {exc}") from exc
