"""The wind flow decoder: the local mean wind field from one LiDAR scan and sparse wind (no torch).

Public API::

    load_decoder(path=None, *, boundary="blend", rotations_deg=None) -> Decoder
                                                the shipped default model, or a model file
    Decoder.offsets, Decoder.predict(scans, w_up, w_robot) -> (B, 2, H, H)
    UpstreamBaseline, LocalBaseline             uniform W_up / uniform W_robot, same signature
    with_baselines(models, size, spacing)       models followed by both baselines on their grid
    field_errors, pooled_errors, improvement    the metrics, defined once
    MeanField, fields_from_store, field_from_solution, draw_samples, DecoderDataset
                                                samples derived on the fly from mean fields

Training (torch) lives in :mod:`windnav.predict.train` and :mod:`windnav.predict.torch_models`
and is imported only by ``windnav train-decoder``.
"""

from windnav.predict.baselines import (
    LocalBaseline,
    UpstreamBaseline,
    check_inputs,
    with_baselines,
)
from windnav.predict.dataset import (
    N_RAYS,
    SCAN_MAX,
    SCAN_MIN,
    SCAN_NOISE,
    DecoderDataset,
    MeanField,
    SampleBatch,
    draw_samples,
    field_from_solution,
    fields_from_store,
    grid_offsets,
    robot_positions,
)
from windnav.predict.decoder import ARCHITECTURES, DEFAULT_MODEL, Decoder, load_decoder
from windnav.predict.metrics import (
    METRICS,
    central_gradients,
    direction_error_breakdown,
    direction_error_cells,
    field_errors,
    improvement,
    pooled_errors,
)

__all__ = [
    "ARCHITECTURES",
    "DEFAULT_MODEL",
    "METRICS",
    "N_RAYS",
    "SCAN_MAX",
    "SCAN_MIN",
    "SCAN_NOISE",
    "Decoder",
    "DecoderDataset",
    "LocalBaseline",
    "MeanField",
    "SampleBatch",
    "UpstreamBaseline",
    "central_gradients",
    "check_inputs",
    "draw_samples",
    "direction_error_breakdown",
    "direction_error_cells",
    "field_errors",
    "field_from_solution",
    "fields_from_store",
    "grid_offsets",
    "improvement",
    "load_decoder",
    "pooled_errors",
    "robot_positions",
    "with_baselines",
]
