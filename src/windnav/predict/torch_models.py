"""Torch modules of the decoder architectures, for training only, and their export.

Each module mirrors the ``network`` part of one architecture of
:mod:`windnav.predict.decoder` (parameter names equal to the NumPy weights' names) and takes
the same feature dict the NumPy architecture's ``features(scans, w_up, w_robot)`` makes
(:func:`windnav.predict.decoder.make_architecture`), as tensors; the fixed parts (D4
canonicalisation, scan pooling, wind scaling) are NumPy only, shared by training and
inference. :func:`export_weights` turns a module into the arrays of a
decoder file; ``tests/test_predict_decoder.py`` checks that the NumPy forward agrees with the
torch forward.

Importing this module imports torch; nothing on the inference path imports it.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from windnav._validate import positive_float, positive_int
from windnav.predict.decoder import N_WIND_FEATURES, Decoder, make_architecture

__all__ = ["D4Film", "ThesisMLP", "build_model", "export_weights", "init_basis_pca",
           "to_decoder", "to_tensors"]


class ThesisMLP(nn.Module):
    """The thesis MLP: ``x (B, n_rays + 4)`` -> depth x width (ReLU) -> ``(B, 2, H^2)`` m/s."""

    def __init__(self, hp: dict):
        super().__init__()
        self.hp = hp
        dims = [hp["n_rays"] + 4] + [hp["width"]] * hp["depth"] + [2 * hp["size"] ** 2]
        self.layers = nn.ModuleList(nn.Linear(a, b) for a, b in zip(dims[:-1], dims[1:],
                                                                     strict=True))

    def forward(self, f: dict) -> torch.Tensor:
        x = f["x"]
        for i, layer in enumerate(self.layers):
            x = layer(x)
            if i < len(self.layers) - 1:
                x = F.relu(x)
        return (x * self.hp["wind_scale"]).view(x.shape[0], 2, -1)


class D4Film(nn.Module):
    """The ``d4-film`` network in the canonical frame (see :mod:`windnav.predict.decoder`).

    ``channels (B, 2, n_rays / pool)``, ``winds (B, 5)``, ``scale (B,)`` m/s and
    ``w_robot (B, 2)`` m/s (canonical) -> canonical field ``(B, 2, H^2)``, m/s:
    ``w_robot + scale * basis(coeff(trunk(FiLM(scan embedding), winds)))``.
    """

    def __init__(self, hp: dict):
        super().__init__()
        self.hp = hp
        c, k, e = hp["conv_channels"], hp["kernel"], hp["embed"]
        n_pooled = hp["n_rays"] // hp["pool"] // 2
        self.conv = nn.Conv1d(2, c, k, padding=k // 2, padding_mode="circular")
        self.embed = nn.Linear(n_pooled * c, e)
        self.film_in = nn.Linear(N_WIND_FEATURES, hp["film_hidden"])
        self.film_out = nn.Linear(hp["film_hidden"], 2 * e)
        dims = [e + N_WIND_FEATURES] + [hp["width"]] * hp["depth"]
        self.trunk = nn.ModuleList(nn.Linear(a, b) for a, b in zip(dims[:-1], dims[1:],
                                                                    strict=True))
        self.coeff = nn.Linear(dims[-1], hp["modes"])
        self.basis = nn.Linear(hp["modes"], 2 * hp["size"] ** 2)
        # FiLM starts as the identity (gamma = beta = 0): the winds first act through the trunk
        nn.init.zeros_(self.film_out.weight)
        nn.init.zeros_(self.film_out.bias)

    def forward(self, f: dict) -> torch.Tensor:
        b = f["channels"].shape[0]
        y = F.max_pool1d(F.relu(self.conv(f["channels"])), 2)
        y = y.transpose(1, 2).reshape(b, -1)  # position-major, as the NumPy forward
        e = self.embed(y)
        gb = self.film_out(F.relu(self.film_in(f["winds"])))
        n_e = e.shape[1]
        h = F.relu(e * (1.0 + gb[:, :n_e]) + gb[:, n_e:])
        h = torch.cat([h, f["winds"]], dim=1)
        for layer in self.trunk:
            h = F.relu(layer(h))
        r = self.basis(self.coeff(h)).view(b, 2, -1)
        return r * f["scale"][:, None, None] + f["w_robot"][:, :, None]


MODULES = {"thesis-mlp": ThesisMLP, "d4-film": D4Film}


def build_model(architecture: str, size: int, **hp) -> nn.Module:
    """A freshly initialised torch module of ``architecture`` for an ``size x size`` grid.

    ``hp`` overrides the architecture's default hyperparameters
    (:func:`windnav.predict.decoder.make_architecture`). The complete hyperparameters are the
    module's ``hp`` attribute.

    ``size`` is at most :data:`windnav.predict.train.MAX_SIZE` (a recipe's ``data.size``
    is odd besides; a module of any size mirrors the NumPy architecture of that size, which
    the tests compare on even grids too).
    """
    # 100001 asked torch for 163 TB (Python API audit, fifty-eighth session)
    from windnav.predict.train import MAX_SIZE

    where = "build_model"
    if architecture not in MODULES:
        raise ValueError(f"The 'architecture' parameter of {where} must be one of "
                         f"{sorted(MODULES)}. Got {architecture!r} instead.")
    if positive_int(size, "size", where) > MAX_SIZE:
        raise ValueError(f"The 'size' parameter of {where} must be at most {MAX_SIZE} (cells "
                         f"per side of the window). Got {size!r} instead.")
    arch = make_architecture(architecture, size, **hp)
    if arch.hp.get("members", 1) != 1:
        raise ValueError("The 'members' hyperparameter of build_model must be 1: a torch module "
                         "is one member (ensembles are assembled from trained members, "
                         f"windnav.predict.decoder.ensemble_decoder). Got {arch.hp['members']!r} "
                         "instead.")
    model = MODULES[architecture](arch.hp)
    model.architecture = architecture
    shapes = arch.shapes()
    names = {k: tuple(v.shape) for k, v in model.state_dict().items()}
    if names != {k: tuple(v) for k, v in shapes.items()}:  # one definition of the parameters
        raise RuntimeError(f"build_model: torch parameters {names} differ from {shapes}")
    return model


def export_weights(model: nn.Module) -> dict:
    """The module's parameters as float32 NumPy arrays, named as in its ``state_dict``."""
    _module(model, "model", "export_weights", built=False)
    return {k: v.detach().to("cpu", torch.float32).numpy().copy()
            for k, v in model.state_dict().items()}


def to_decoder(model: nn.Module, metadata: dict | None = None) -> Decoder:
    """The NumPy :class:`Decoder` of a torch module (``metadata`` is added to its own;
    ``spacing``, m between the window's cells, 1 by default)."""
    where = "to_decoder"
    _module(model, "model", where)
    if metadata is not None and not isinstance(metadata, dict):
        raise ValueError(f"The 'metadata' parameter of {where} must be a dict or None. Got "
                         f"{metadata!r} instead.")
    if metadata is not None and "spacing" in metadata:  # -1 was grid_offsets' 'spacing'
        try:
            positive_float(metadata["spacing"], "spacing", where)
        except ValueError:
            raise ValueError(f"The 'metadata' parameter of {where} must have spacing a finite "
                             f"number > 0, m. Got {metadata['spacing']!r} instead.") from None
    meta = {**(metadata or {}), "architecture": model.architecture,
            "hyperparameters": dict(model.hp), "size": model.hp["size"]}
    meta.setdefault("spacing", 1.0)
    return Decoder(export_weights(model), meta)


INPUTS = {"thesis-mlp": ("x",), "d4-film": ("channels", "winds", "scale", "w_robot")}
"""The feature arrays each module reads (the others serve the NumPy frame change)."""


def to_tensors(features: dict, architecture: str, device="cpu") -> dict:
    """The network inputs of an architecture's feature dict as float32 tensors on ``device``."""
    # {} met KeyError 'channels', an unknown architecture a KeyError and {'x': 'abc'} NumPy's
    # "could not convert string to float" (Python API audit, fifty-eighth session)
    where = "to_tensors"
    if architecture not in INPUTS:
        raise ValueError(f"The 'architecture' parameter of {where} must be one of "
                         f"{sorted(INPUTS)}. Got {architecture!r} instead.")
    missing = [k for k in INPUTS[architecture]
               if not isinstance(features, Mapping) or k not in features]
    if missing:
        raise ValueError(f"The 'features' parameter of {where} must be a dict holding "
                         f"{list(INPUTS[architecture])} (the architecture's features). Got "
                         + (f"one without {missing}" if isinstance(features, Mapping)
                            else repr(features)) + " instead.")
    out = {}
    for k in INPUTS[architecture]:
        try:
            a = np.ascontiguousarray(features[k], dtype=np.float32)
        except (TypeError, ValueError):
            raise ValueError(f"The 'features' parameter of {where} must hold arrays of "
                             f"numbers. Got {features[k]!r} at {k!r} instead.") from None
        out[k] = torch.from_numpy(a).to(device)
    return out


def init_basis_pca(model: nn.Module, residuals: np.ndarray) -> np.ndarray:
    """Initialise a ``d4-film`` basis with the principal components of training residuals.

    Parameters
    ----------
    model : D4Film
    residuals : ndarray of shape (n, 2 H^2)
        ``(label - W_robot) / U`` in the canonical frame, 0 in buildings.

    Returns
    -------
    ndarray of shape (modes,)
        Fraction of the residuals' variance each mode explains.

    The bias becomes the mean residual and column ``k`` of the basis the ``k``-th component
    times its standard deviation, so the coefficients to learn have unit variance.
    """
    # a thesis-mlp met KeyError 'modes'; no rows set the bias to NaN with only warnings, 7
    # columns met a torch RuntimeError and NaN a LinAlgError (Python API audit, fifty-eighth
    # session)
    where = "init_basis_pca"
    _module(model, "model", where)
    if not isinstance(model, D4Film):
        raise ValueError(f"The 'model' parameter of {where} must be a d4-film module (the "
                         f"thesis-mlp has no basis). Got a {model.architecture!r} module "
                         "instead.")
    n_cells = 2 * model.hp["size"] ** 2
    try:
        r = np.asarray(residuals, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"The 'residuals' parameter of {where} must be an array of numbers. "
                         f"Got {residuals!r} instead.") from None
    if r.ndim != 2 or r.shape[0] < 1 or r.shape[1] != n_cells:  # (one row: a zero basis, as a
        # recipe with one training sample always had; review)
        raise ValueError(f"The 'residuals' parameter of {where} must be an array of shape (n, "
                         f"{n_cells}) with n >= 1 (2 H^2 for H = {model.hp['size']}). Got shape "
                         f"{r.shape} instead.")
    if not np.isfinite(r).all():
        raise ValueError(f"The 'residuals' parameter of {where} must be finite (no NaN or inf). "
                         "Got non-finite entries instead.")
    mean = r.mean(axis=0)
    k = model.hp["modes"]
    s, vt, total = _top_components(r - mean, k)
    std = s / np.sqrt(max(r.shape[0] - 1, 1))
    comps = np.zeros((k, r.shape[1]))
    sd = np.zeros(k)
    n = min(k, vt.shape[0])
    comps[:n], sd[:n] = vt[:n], std[:n]
    with torch.no_grad():
        model.basis.weight.copy_(torch.from_numpy((comps * sd[:, None]).T))
        model.basis.bias.copy_(torch.from_numpy(mean))
    out = np.zeros(k)
    out[:n] = s[:n] ** 2 / (total or 1.0)
    return out


def _module(model, name: str, where: str, built: bool = True) -> None:
    """A ValueError naming ``name`` unless ``model`` is a torch module (``built``: one of
    :func:`build_model`, with its ``architecture`` and ``hp``); a Linear or a dict met an
    AttributeError (Python API audit, fifty-eighth session)."""
    if not isinstance(model, nn.Module) or (built and not (
            isinstance(getattr(model, "hp", None), dict)
            and getattr(model, "architecture", None) in MODULES)):
        raise ValueError(f"The {name!r} parameter of {where} must be a torch module"
                         + (" made by build_model" if built else "") + f". Got {model!r} instead.")


def _top_components(x: np.ndarray, k: int, oversample: int = 16, power: int = 3):
    """The ``k`` leading singular values and right singular vectors of ``x`` (n, d), and its
    total squared norm, by a randomized range finder with power iterations (Halko, Martinsson
    & Tropp 2011, alg. 4.4) with a fixed seed: a few products of ``x`` instead of a full SVD.
    In torch, so that it keeps to ``torch.set_num_threads``."""
    t = torch.from_numpy(np.ascontiguousarray(x, dtype=np.float64))
    total = float((t * t).sum())
    m = min(k + oversample, *x.shape)
    if m >= min(x.shape):
        _, s, vt = torch.linalg.svd(t, full_matrices=False)
    else:
        omega = torch.from_numpy(np.random.default_rng(0).standard_normal((x.shape[1], m)))
        q = torch.linalg.qr(t @ omega)[0]
        for _ in range(power):
            q = torch.linalg.qr(t.T @ q)[0]
            q = torch.linalg.qr(t @ q)[0]
        _, s, vt = torch.linalg.svd(q.T @ t, full_matrices=False)
    return s[:k].numpy(), vt[:k].numpy(), total
