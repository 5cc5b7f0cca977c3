"""State estimation: generic UKF, the Wind UKF model, observability, a-priori uncertainty.

Public API::

    UKF, ukf_predict, ukf_update, merwe_weights, ...   generic unscented Kalman filter
    WindUKF, WindEstimate, wind_world                  the thesis' wind estimator (ch. 3)
    check_noise                                        its rules for the noise settings q and r
    wind_model, layout                                 its batched models and packed layouts
    observability                                      Lie-derivative rank analysis (sympy)
    wind_uncertainty, wind_uncertainty_axes, ...       a-priori wind uncertainty (appendix A)
    drag_model_bias                                    a filter's bias from another drag model
    run_wind_ukf, WindTrack, filter_inputs             the Wind UKF over a recorded flight
    fit_drag, DragFit                                  drag calibration by least squares
    UKFConditions, CONDITIONS, ukf_conditions          named sensing + filter presets
    OdometryAccel, odometry_specific_force             the hardware's differenced-mocap accel

The calibration *flights* (``calibrate``, ``calibration_flights``) fly the simulator and live in
:mod:`windnav.experiments.calibration`.
"""

from windnav.estimate import conditions, hardware, layout, observability, wind_model
from windnav.estimate.calibrate import DragFit, fit_drag
from windnav.estimate.conditions import CONDITIONS, UKFConditions, ukf_conditions
from windnav.estimate.flight import WindTrack, filter_inputs, run_wind_ukf
from windnav.estimate.hardware import OdometryAccel, odometry_specific_force
from windnav.estimate.ukf import (
    UKF,
    FilterDivergedError,
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
    drag_model_bias,
    wind_uncertainty,
    wind_uncertainty_axes,
)
from windnav.estimate.wind_ukf import (
    DEFAULT_Q,
    DEFAULT_R,
    WindEstimate,
    WindUKF,
    check_noise,
    sensor_range,
    wind_world,
)

__all__ = [
    "CONDITIONS",
    "DEFAULT_Q",
    "DEFAULT_R",
    "UKF",
    "FilterDivergedError",
    "PredictResult",
    "SigmaWeights",
    "UpdateResult",
    "DragFit",
    "OdometryAccel",
    "UKFConditions",
    "WindTrack",
    "filter_inputs",
    "fit_drag",
    "hardware",
    "layout",
    "run_wind_ukf",
    "WindEstimate",
    "WindUKF",
    "sensor_range",
    "check_noise",
    "compare_vehicles",
    "drag_model_bias",
    "conditions",
    "merwe_weights",
    "observability",
    "odometry_specific_force",
    "robust_cholesky",
    "sigma_points",
    "ukf_predict",
    "ukf_conditions",
    "ukf_update",
    "unscented_transform",
    "wind_model",
    "wind_uncertainty",
    "wind_uncertainty_axes",
    "wind_world",
]
