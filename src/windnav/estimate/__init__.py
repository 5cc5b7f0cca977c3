"""State estimation: generic UKF, the Wind UKF model, observability, a-priori uncertainty.

Public API::

    UKF, ukf_predict, ukf_update, merwe_weights, ...   generic unscented Kalman filter
    WindUKF, WindEstimate, wind_world                  the thesis' wind estimator (ch. 3)
    wind_model                                         its batched process/measurement models
    observability                                      Lie-derivative rank analysis (sympy)
    wind_uncertainty, wind_uncertainty_axes, ...       a-priori wind uncertainty (appendix A)
    run_wind_ukf, WindTrack, filter_inputs             the Wind UKF over a recorded flight
    calibrate, fit_drag, calibration_flights, DragFit  drag calibration by least squares
"""

from windnav.estimate import observability, wind_model
from windnav.estimate.calibrate import DragFit, calibrate, calibration_flights, fit_drag
from windnav.estimate.flight import WindTrack, filter_inputs, run_wind_ukf
from windnav.estimate.ukf import (
    UKF,
    PredictResult,
    SigmaWeights,
    UpdateResult,
    merwe_weights,
    robust_cholesky,
    sigma_points,
    ukf_predict,
    ukf_update,
    unscented_transform,
)
from windnav.estimate.uncertainty import (
    compare_vehicles,
    wind_uncertainty,
    wind_uncertainty_axes,
)
from windnav.estimate.wind_ukf import DEFAULT_Q, DEFAULT_R, WindEstimate, WindUKF, wind_world

__all__ = [
    "DEFAULT_Q",
    "DEFAULT_R",
    "UKF",
    "PredictResult",
    "SigmaWeights",
    "UpdateResult",
    "DragFit",
    "WindTrack",
    "calibrate",
    "calibration_flights",
    "filter_inputs",
    "fit_drag",
    "run_wind_ukf",
    "WindEstimate",
    "WindUKF",
    "compare_vehicles",
    "merwe_weights",
    "observability",
    "robust_cholesky",
    "sigma_points",
    "ukf_predict",
    "ukf_update",
    "unscented_transform",
    "wind_model",
    "wind_uncertainty",
    "wind_uncertainty_axes",
    "wind_world",
]
