"""System identification, energetics and similitude (the thesis's chapter 6), from data files
to coefficients.

Public API::

    read_table, read_bag, parse_topic_map, Table, LAYOUTS     CSV / whitespace / ROS bag input
    Estimate, LeastSquares                                    a coefficient with its 95% CI
    PWMMotorModel, fit_thrust_stand, steady_mask              thrust stand: k_eta, Kv, V0, DZ
    AeroData, fit_aero, aero_from_flight_log                  tunnel hover: k_eta, k_d, k_z, k_h
    aero_and_status_from_flight_log                           the same, samples by vehicle status
    fit_power, steady_level_mask                              power curve and best speeds
    Similitude                                                Froude / Reynolds scaling
    unsteadiness_maps, FlightSamples                          binned flow and unsteadiness

Every fit is a pure function returning a frozen result with estimates, 95% confidence
intervals (least-squares covariance, t distribution), R^2 and residuals; figures and the
simulated experiments live in :mod:`windnav.experiments.sysid`.
"""

from windnav.sysid._fit import Estimate, LeastSquares
from windnav.sysid.aero import (
    AERO_COLUMNS,
    AeroData,
    AeroFit,
    aero_and_status_from_flight_log,
    aero_columns,
    aero_from_flight_log,
    block_average,
    fit_aero,
)
from windnav.sysid.io import LAYOUTS, Table, parse_topic_map, read_bag, read_table, write_csv
from windnav.sysid.power import DEFAULT_WINDS, PowerFit, fit_power, steady_level_mask
from windnav.sysid.similitude import Similitude
from windnav.sysid.thrust_stand import (
    STAND_COLUMNS,
    PWMMotorModel,
    ThrustStandFit,
    fit_thrust_stand,
    steady_mask,
)
from windnav.sysid.unsteadiness import (
    UNSTEADINESS_COLUMNS,
    FlightSamples,
    UnsteadinessMaps,
    bin_xy,
    flight_samples_from_log,
    lateral_force_command,
    unsteadiness_maps,
)

__all__ = [
    "AERO_COLUMNS",
    "DEFAULT_WINDS",
    "LAYOUTS",
    "STAND_COLUMNS",
    "UNSTEADINESS_COLUMNS",
    "AeroData",
    "AeroFit",
    "Estimate",
    "FlightSamples",
    "LeastSquares",
    "PWMMotorModel",
    "PowerFit",
    "Similitude",
    "Table",
    "ThrustStandFit",
    "UnsteadinessMaps",
    "aero_columns",
    "aero_and_status_from_flight_log",
    "aero_from_flight_log",
    "bin_xy",
    "block_average",
    "fit_aero",
    "fit_power",
    "fit_thrust_stand",
    "flight_samples_from_log",
    "lateral_force_command",
    "parse_topic_map",
    "read_bag",
    "read_table",
    "steady_level_mask",
    "steady_mask",
    "unsteadiness_maps",
    "write_csv",
]
