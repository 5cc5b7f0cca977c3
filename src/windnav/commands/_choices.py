"""Choices of the command-line options, named here so that building the parser (``windnav
--help``, every command's start) does not import the packages that define them: the Wind
UKF's conditions pulled in the vehicle models and SciPy's integrators, the sys-id table
layouts SciPy's statistics, ``fly``'s winds the sensors, its trajectories and the
vehicles Numba, ``navigate``'s variants the planner.
``tests/test_command_examples.py`` checks each against its source."""

from __future__ import annotations

CONDITION_NAMES = ("windnav", "thesis", "thesis-0.038", "hardware")
"""The keys of :data:`windnav.estimate.conditions.CONDITIONS`, in order."""

TABLE_LAYOUTS = ("optimal_energy_quad",)
"""The keys of :data:`windnav.sysid.io.LAYOUTS`, sorted."""

ENERGY_MODES = ("horizon", "mission")
""":data:`windnav.plan.ENERGY_MODES`, what an energy-aware planner's ``J_E`` measures."""

NAV_VARIANTS = ("mppi", "mppi-w", "ea-mppi", "ea-mppi-w", "gs", "gs-w", "ea-mppi-w-hat",
                "ea-mppi-w-esc")
"""The keys of :data:`windnav.plan.VARIANTS`, in order: ``navigate``'s planners."""

UNAWARE_VARIANTS = ("mppi", "mppi-w", "gs", "gs-w")
"""The variants without an energy term in an MPPI cost
(:func:`windnav.commands.navigate.energy_aware_variants` are the others)."""

TRAJECTORIES = ("hover", "line", "circle", "waypoints")
""":data:`windnav.sim.trajectories.TRAJECTORIES`, the references of ``windnav fly``."""

VEHICLES = ("hummingbird", "crazyflie_brushless", "crazyflie_thesis")
""":data:`windnav.vehicle.params.VEHICLES`, the vehicles the commands fly."""

WIND_KINDS = ("none", "constant", "dryden")
""":data:`windnav.experiments.flight.WIND_KINDS`, the winds of ``windnav fly``."""
