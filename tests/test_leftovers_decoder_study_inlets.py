"""``decoder-study direction|basis --windinet``: whose inlets (leftovers, 2026-12-05).

Its docstring said these studies run at the inlets of ``windnav evaluate-decoder``; the layout
is their map 0, so its inlets are evaluate-decoder's only with ``--maps 0`` (and the same
``--seed`` and ``--inlets``): evaluate-decoder's default three dense maps put the layout at map
3, whose inlets are others. The flows here are stand-ins that record their inlet and diverge.
"""

from __future__ import annotations

import argparse

import pytest
from test_decoder_eval import tiny_decoder, tiny_maps

import windnav.commands.decoder_study as decoder_study
from windnav.city import write_rotorpy_json
from windnav.experiments.decoder_eval import evaluate_decoder
from windnav.flow.solver import FlowDivergedError


def recorder(layout):
    """A stand-in for ``simulate``: the (speed, direction) of each flow on ``layout``."""
    seen = []

    def simulate(city, *, speed, direction_deg, **kw):
        if city is layout or (city.footprints.shape == layout.footprints.shape
                              and (city.footprints == layout.footprints).all()):
            seen.append((round(speed, 9), round(direction_deg, 9)))
        raise FlowDivergedError("a stand-in")

    return seen, simulate


def test_the_windinet_inlets_are_evaluate_decoders_only_with_its_maps_0(tmp_path, monkeypatch):
    assert "evaluate-decoder --maps 0`` with the same ``--seed`` and ``--inlets``" in \
        " ".join(decoder_study.__doc__.split())
    (name, layout), = tiny_maps(1)  # stands in for the windinet layout
    path = write_rotorpy_json(layout, tmp_path / "layout.json")
    monkeypatch.setattr(decoder_study, "_windinet_map", lambda: layout)
    args = argparse.Namespace(study="direction", windinet=True, quick=False, maps=1, inlets=3,
                              seed=5, flow_cache=None, map=None)
    study, simulate = recorder(layout)
    with pytest.raises(ValueError, match="every flow failed"):
        decoder_study._fields(args, "windnav decoder-study", simulate, False)
    assert len(study) == 3

    def evaluated(maps):
        seen, simulate = recorder(layout)
        try:
            evaluate_decoder(maps=maps, windinet=path, n_inlets=3, seed=5, dx=2.0,
                             flow_settings={"spinup_steps": 1, "steps": 1},
                             decoder=tiny_decoder(), simulate=simulate)
        except ValueError:
            pass  # every slot diverged: nothing to score
        return seen

    assert evaluated(0) == study                        # --maps 0: the same inlets
    other = evaluated(tiny_maps(4)[1:])                 # three dense maps before it
    assert len(other) == 3 and set(other).isdisjoint(study)
