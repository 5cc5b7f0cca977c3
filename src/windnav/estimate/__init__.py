"""State estimation: generic UKF, the Wind UKF model, observability, a-priori uncertainty.

Public API::

    UKF, ukf_predict, ukf_update, merwe_weights, ...   generic unscented Kalman filter
    WindUKF, WindEstimate, wind_world                  the thesis' wind estimator (ch. 3)
    wind_model                                         its batched process/measurement models
    observability                                      Lie-derivative rank analysis (sympy)
    wind_uncertainty, wind_uncertainty_axes, ...       a-priori wind uncertainty (appendix A)
"""

from windnav.estimate import observability, wind_model
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
