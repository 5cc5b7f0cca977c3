"""``windnav similitude``: Froude and Reynolds scaling between a full-scale aircraft and a model.

::

    windnav similitude --scale 32 --full-scale-mass 2000 --full-scale-speed 10 \\
        --control-rate-hz 500 --obstacle-width 0.3

The same command as ``windnav sysid similitude`` (:class:`windnav.sysid.Similitude`): the
length scale is the ratio of rotor diameters (default the thesis's 1.8 m air-taxi rotor against
the Crazyflie's 55 mm); it prints, and writes with ``--json``, the model speed, mass and
frequencies under Froude similarity, the speed Reynolds similarity would need, and the ratio of
the control rate to the shedding frequency at both scales. The shedding needs
``--obstacle-width`` with ``--control-rate-hz`` and a speed; an option the report would not
use (``--obstacle-width`` without them, ``--strouhal`` without ``--obstacle-width``,
``--kinematic-viscosity`` without a speed) is refused, not ignored.
"""

from __future__ import annotations

from windnav.commands.sysid import add_similitude_arguments, run_similitude


def register(sub) -> None:
    p = sub.add_parser("similitude", help="Froude and Reynolds scaling between a full-scale "
                                          "aircraft and a model",
                       description="Length scale = ratio of rotor diameters; Froude scaling "
                                   "of speed, mass, time and frequency; the speed Reynolds "
                                   "similarity would need; f_control / f_shed at both scales.")
    add_similitude_arguments(p)
    p.set_defaults(func=run)


def run(args) -> int:
    return run_similitude(args)
