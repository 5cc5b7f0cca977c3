"""What the documentation figures show: titles without Python reprs, legends and labels off the
data, differences the text discusses on an axis that shows them, colour bars that say where the
colour scale clips, paths that stay visible where they coincide, legend names from the data.

The figures are drawn from the committed results in ``docs/`` where those hold what the
figure needs, else from small synthetic results of the same shape."""

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import windnav.viz.decoder as vd
import windnav.viz.nav_studies as vn
from windnav.viz.nav_compare import COLORS, colour_extend, draw_paths, path_widths

DOCS = Path(__file__).resolve().parents[1] / "docs"


def _doc(name: str) -> dict:
    return json.loads((DOCS / name).read_text())


@pytest.fixture
def drawn(monkeypatch):
    """``drawn(module, function_name)``: wrap ``module.function_name`` (the module's writer of
    the figure) so that the figure it writes is kept; returns the list of kept figures, each
    drawn as written."""
    figures = []

    def keep(module, name):
        original = getattr(module, name)

        def wrapper(fig, *args, **kwargs):
            out = original(fig, *args, **kwargs)
            fig.canvas.draw()
            figures.append(fig)
            return out

        monkeypatch.setattr(module, name, wrapper)
        return figures

    return keep


def _crossed(bbox, ax) -> list[str]:
    """The lines and bars of ``ax`` that pass through ``bbox`` (display coordinates)."""
    hit = []
    for line in ax.get_lines():
        if line.get_transform().transform_path(line.get_path()).intersects_bbox(bbox,
                                                                                 filled=False):
            hit.append(f"line {line.get_label()!r}")
    hit += [f"bar at {p.get_x():.2f}" for p in ax.patches
            if p.get_height() > 0 and p.get_window_extent().overlaps(bbox)]
    return hit


# ------------------------------------------------------------------------- decoder studies


def test_winds_ablation_title_gives_the_hyperparameters_as_text_not_a_dict(drawn, tmp_path):
    figs = drawn(vd, "_save")
    vd.plot_winds_ablation(_doc("data/decoder_winds.json"), tmp_path / "w.png")
    title = figs[0]._suptitle.get_text()
    assert "thesis-mlp (width 256, depth 3)" in title
    assert not set("{}'") & set(title)
    assert vd._settings({"width": 64, "film": {"depth": 2}}) == "width 64, film (depth 2)"


def test_noise_study_draws_each_decoder_against_the_first_without_noise(drawn, tmp_path):
    result = _doc("data/decoder_noise.json")
    figs = drawn(vd, "_save")
    vd.plot_noise(result, tmp_path / "n.png")
    axes = figs[0].axes
    assert len(axes) == 4
    decoders = [m for m in result["errors"] if m not in ("local", "upstream")]
    for col, metric in enumerate(("speed_error", "direction_error_deg")):
        top, diff = axes[col], axes[2 + col]
        base = result["errors"]["decoder"][0][metric]
        curves = {line.get_label(): line.get_ydata() for line in diff.get_lines()
                  if not line.get_label().startswith("_")}
        assert list(curves) == decoders
        for m in decoders:
            np.testing.assert_allclose(curves[m], [e[metric] - base
                                                   for e in result["errors"][m]])
        # the differences the text reads (0.13 m/s, 3.1 deg at 0.15 U) fill the bottom axis,
        # which the top one's range (the baselines, from 0) squeezes into a few pixels
        spread = np.ptp(np.concatenate(list(curves.values())))
        assert np.ptp(diff.get_ylim()) < 1.5 * spread
        assert np.ptp(top.get_ylim()) > 10 * spread
        assert "with exact W_robot" in diff.get_ylabel()
    # without a noise-free level, the reference is the lowest one, and the label says so
    errors = {m: [{"speed_error": 1.0 + v, "direction_error_deg": 10.0 + v} for v in (2, 1)]
              for m in ("decoder", "local", "upstream")}
    vd.plot_noise({"levels": [0.1, 0.05], "errors": errors, "n_samples": 8}, tmp_path / "m.png")
    diff = figs[1].axes[2]
    assert "with W_robot noise 0.05 U" in diff.get_ylabel()
    np.testing.assert_allclose(diff.get_lines()[0].get_ydata(), [1.0, 0.0])


def test_basis_legend_sits_above_the_modes_panel_off_its_bars_and_line(drawn, tmp_path):
    figs = drawn(vd, "_save")
    vd.plot_basis(_doc("data/decoder_basis.json"), tmp_path / "b.png")
    fig = figs[0]
    ax = next(a for a in fig.axes if a.get_legend() is not None
              and "decoder R^2 on it" in [t.get_text() for t in a.get_legend().get_texts()])
    twin = next(a for a in fig.axes if a is not ax and a.bbox.bounds == ax.bbox.bounds)
    box = ax.get_legend().get_window_extent()
    assert _crossed(box, ax) == [] and _crossed(box, twin) == []
    assert box.y0 >= ax.bbox.y1 - 1  # above the data, whatever the data
    assert box.y1 <= fig.bbox.y1


def test_eigenflow_counts_are_in_the_legend_not_written_over_the_curves(drawn, tmp_path):
    rng = np.random.default_rng(0)
    frames = {}
    for f, first in (("world", 0.51), ("canonical", 0.34)):
        ratio = np.diff(1 - (1 - first) * np.exp(-np.arange(0, 400) / 3.0), prepend=0.0)
        ratio[0] = first
        cum = np.cumsum(ratio)
        frames[f] = {"explained_variance_ratio": ratio, "cumulative": cum,
                     "n_modes": {"0.98": int(np.argmax(cum >= 0.98)) + 1}}
    frames["world"]["modes"] = rng.normal(size=(8, 2, 9, 9))
    result = {**frames, "size": 9, "spacing": 1.0, "n_fields": 64}
    figs = drawn(vd, "_save")
    vd.plot_eigenflows(result, tmp_path / "e.png")
    ax = figs[0].axes[0]
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert f"world frame (98 %: {frames['world']['n_modes']['0.98']} modes)" in labels
    assert f"canonical D4 frame (98 %: {frames['canonical']['n_modes']['0.98']} modes)" in labels
    for text in [*ax.texts, ax.get_legend()]:
        assert _crossed(text.get_window_extent(), ax) == []


def test_the_mode_panels_share_one_colour_scale_with_its_bar(drawn, tmp_path):
    """The eigenflow and basis figures coloured each mode's magnitude on its own scale, with
    no colour bar (figures audit, 2026-12-05)."""
    figs = drawn(vd, "_save")
    eigen = _doc("data/decoder_eigenflows.json")  # its modes are not in the JSON: drawn ones
    modes = np.random.default_rng(0).normal(size=(8, 2, 25, 25))
    eigen["world"]["modes"] = modes / np.linalg.norm(modes.reshape(8, -1), axis=1)[:, None,
                                                                                   None, None]
    vd.plot_eigenflows({**eigen, "size": 25, "spacing": 1.0}, tmp_path / "e.png")
    basis = _doc("data/decoder_basis_windinet.json")  # nor are these fields
    vd.plot_basis({**basis, "eigenflow_fields": modes[:4]}, tmp_path / "b.png")
    for fig, label in zip(figs, ("|mode| per cell", "|eigenflow| per cell"), strict=True):
        bars = [a for a in fig.axes if a.get_ylabel().startswith(label)]
        assert len(bars) == 1
        limits = {tuple(m.get_clim()) for a in fig.axes if a is not bars[0]
                  for m in [*a.collections, *a.images] if m.get_array() is not None
                  and m.get_cmap().name == "viridis"}
        assert len(limits) == 1 and next(iter(limits))[0] == 0.0, limits


# ------------------------------------------------------------------------- navigation


def _wind(clip: bool):
    """A 100 m map, one building, a nearly uniform wind; ``clip``: a few cells far above the
    rest (beyond the colour scale's 99th percentile)."""
    x = y = np.arange(0.5, 100.0, 1.0)
    xx, yy = np.meshgrid(x, y)
    solid = (xx > 20) & (xx < 40) & (yy > 60) & (yy < 80)
    u = np.full(xx.shape, 4.0) + 0.01 * xx
    if clip:
        u[:20, 0] = 30.0  # 0.2 % of the cells
    flow = SimpleNamespace(x=x, y=y, dx=1.0, solid=solid, mean_u=np.where(solid, 0.0, u),
                           mean_v=np.zeros_like(u))
    city = SimpleNamespace(footprints=[(20.0, 40.0, 60.0, 80.0)], bounds=(0.0, 100.0, 0.0, 100.0))
    return city, flow


def _flight(offset: float, n: int = 50):
    t = np.linspace(0.0, 1.0, n)
    position = np.stack([10 + 80 * t, 30 + 20 * t + offset, np.full(n, 5.0)], axis=1)
    return SimpleNamespace(position=position, start=position[0, :2], goal=position[-1, :2],
                           outcome="success", energy_J=2000.0, time_s=30.0, route=None)


@pytest.mark.parametrize("clip, extend", [(True, "max"), (False, "neither")])
def test_clipped_wind_colour_bars_carry_an_arrow(clip, extend):
    import matplotlib.pyplot as plt

    city, flow = _wind(clip)
    fig, ax = plt.subplots()
    draw_paths(fig, ax, {"A": _flight(0.0)}, city, flow)
    im = ax.images[0]
    assert im.colorbar.extend == extend
    speed = np.hypot(flow.mean_u, flow.mean_v)[~flow.solid]
    assert (speed.max() > im.norm.vmax) == clip
    plt.close(fig)
    im.set_clim(4.5, 10.0)  # the buildings (0, masked) are not below it
    assert colour_extend(im) == ("both" if clip else "min")


def test_gust_figure_marks_both_clipped_colour_scales(drawn, tmp_path):
    city, flow = _wind(True)
    sigma = np.where(flow.solid, 0.0, 0.1 * flow.mean_u)
    flights = {v: SimpleNamespace(position=_flight(float(k)).position, outcome="success",
                                  summary=lambda: {"arrival_time_s": 20.0})
               for k, v in enumerate(("base", "base@gust=0.5"))}
    scenario = SimpleNamespace(start=(10.0, 30.0), goal=(90.0, 50.0), scenario_id="t/m00/w00/p0",
                               kind="headwind", speed=4.0, direction_deg=0.0)
    result = {"scenario": scenario, "city": city, "flow": flow, "sigma_along": sigma,
              "flights": flights, "routes": {}, "gust_k": 0.5}
    figs = drawn(vn, "_finish")
    vn.plot_gust_routes(result, tmp_path / "g.png")
    images = [a.images[0] for a in figs[0].axes if a.images]
    assert len(images) == 2
    assert [im.colorbar.extend for im in images] == ["max", "max"]


def test_coinciding_paths_stay_visible_each_under_a_thinner_later_one():
    import matplotlib.pyplot as plt

    city, flow = _wind(False)
    results = {name: _flight(0.0) for name in ("MPPI", "EA-MPPI+W", "GS", "GS+W")}
    fig, ax = plt.subplots()
    draw_paths(fig, ax, results, city, flow)
    xs = results["MPPI"].position[:, 0]
    drawn_paths = [line for line in ax.get_lines() if np.array_equal(line.get_xdata(), xs)]
    outlines = [line for line in drawn_paths if line.get_color() == "k"]
    coloured = [line for line in drawn_paths if line.get_color() != "k"]
    assert [line.get_color() for line in coloured] == list(COLORS)
    widths = [line.get_linewidth() for line in coloured]
    assert widths == path_widths(4) and all(np.diff(widths) < 0)
    assert all(np.diff([line.get_zorder() for line in coloured]) > 0)
    # every outline under every path: a later path's outline hides no earlier path's colour
    assert max(o.get_zorder() for o in outlines) < min(c.get_zorder() for c in coloured)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels[:4] == [f"{n}: success, 2.00 kJ, 30 s" for n in results]
    plt.close(fig)


def test_inflight_legend_names_the_compared_decoders_from_the_data(drawn, tmp_path):
    result = _doc("img/navigation/nav_inflight_compare.json")
    assert result["models"]["shipped"].endswith("decoder_default.npz")
    figs = drawn(vn, "_finish")
    vn.plot_inflight(result, tmp_path / "a.png", labels={"shipped": "2026-11-26 default"})
    vn.plot_inflight(result, tmp_path / "b.png")
    named, default = ([t.get_text() for t in fig.legends[0].get_texts()] for fig in figs)
    assert "2026-11-26 default, W_robot from the UKF" in named
    assert not any(text.startswith("shipped") for text in named)
    assert "flight (2026-11-29-flight), W_robot from the UKF" in named
    assert "shipped (default), mean W_robot" in default
    for fig in figs:  # the longer names wrap into rows instead of off the figure
        box = fig.legends[0].get_window_extent()
        assert box.x0 >= 0 and box.x1 <= fig.bbox.x1
    with pytest.raises(ValueError, match="'labels' parameter of plot_inflight.*'default'"):
        vn.plot_inflight(result, tmp_path / "c.png", labels={"default": "x"})


def test_the_label_studies_and_the_mosaic_mark_their_clipped_colour_scales():
    """The start study's spread map stops at its 99th percentile and the mosaic's speeds at
    quantiles: their colour bars carry an arrow where the data pass the scale (audit,
    2026-12-05), and none where they do not."""
    import matplotlib.pyplot as plt

    errors = {m: {"speed_error": 1.0, "direction_error_deg": 10.0} for m in vd._MODELS}
    for image, extend in ((np.linspace(0.0, 2.0, 400).reshape(20, 20), "max"),
                          (np.full((20, 20), 0.01), "neither")):
        fig, axes = vd._label_study_figure([("a", errors)], image, vmax=1.0,
                                           colorbar_label="spread", title="t")
        assert axes[2].images[0].colorbar.extend == extend
        plt.close(fig)


# ------------------------------------------------------------------------- flight figures

def test_the_3d_flight_path_has_one_scale_on_its_three_axes(drawn, tmp_path):
    """A 6 m circle flown at 2 m with a 5 cm altitude wobble: each axis scaled to its own
    range made the wobble look as large as the circle (figures audit, 2026-12-05)."""
    import windnav.viz.flight as vf

    kept = drawn(vf, "_save")
    t = np.linspace(0.0, 10.0, 200)
    target = np.column_stack([3 * np.cos(t), 3 * np.sin(t), np.full_like(t, 2.0)])
    flown = target + np.column_stack([0 * t, 0 * t, 0.05 * np.sin(5 * t)])
    zeros = np.zeros((t.size, 1, 3))
    log = SimpleNamespace(t=t, position=flown[:, None], target_position=target,
                          velocity=zeros, wind=zeros, energy=np.zeros((t.size, 1)),
                          power=np.zeros((t.size, 1)), rotor_speed=np.zeros((t.size, 1, 4)))
    try:
        vf.plot_flight(log, tmp_path)
    except AttributeError:  # the time series want more of a log; the path is drawn first
        pass
    ax = kept[0].axes[0]
    spans = [np.ptp(lim) for lim in (ax.get_xlim3d(), ax.get_ylim3d(), ax.get_zlim3d())]
    np.testing.assert_allclose(spans, spans[0], rtol=1e-9)
    assert spans[0] >= 5.9  # the circle, not the wobble


def test_a_flight_keeps_its_colour_between_the_paths_the_bars_and_the_energy_curves(drawn,
                                                                                    tmp_path):
    """`nav-study gs` and `cases` draw the same flights as paths (over the wind), bars and
    energy curves: the energy curves took blue for the second flight, which the bars draw grey
    and its path white, and the bars' blue is the fourth flight's (figures audit, 2026-12-05)."""
    import matplotlib.colors as mc

    import windnav.viz.nav_compare as nc
    from windnav.viz.nav_compare import COLORS_ON_WHITE, plot_energy

    kept = drawn(nc, "_save")
    t = np.linspace(0.0, 5.0, 20)
    flight = SimpleNamespace(t=t, airspeed=t, power=t, energy=t, rotor_energy=t, energy_J=5.0,
                             rotor_energy_J=5.0, outcome="success")
    plot_energy({name: flight for name in ("A", "B", "C", "D")}, tmp_path / "e.png")
    solid = [ln for ln in kept[0].axes[0].get_lines()]
    assert [mc.to_hex(ln.get_color()) for ln in solid] == [mc.to_hex(c) for c in COLORS_ON_WHITE]
    assert mc.to_hex(COLORS_ON_WHITE[1]) == mc.to_hex("tab:gray")  # white's, on white


def test_the_pace_legend_keys_do_not_cover_each_other(drawn, tmp_path):
    """A markerscale for every key made the thesis's star cover the key of the row above it,
    the green points the text points readers to (figures audit, 2026-12-05). The keys' drawn
    extents, top down, must not overlap: a line's (with its marker) from its window extent, a
    scatter key's from its offset and marker size (its own window extent is empty)."""
    from matplotlib.collections import PathCollection

    import windnav.viz.nav_sweeps as vs

    kept = drawn(vs, "_save")
    vs.plot_pace(_doc("img/navigation/nav_pace.json"), tmp_path / "pace.png")
    fig = kept[0]
    spans = []  # (bottom, top) of each key, in pixels
    for handle in fig.axes[0].get_legend().legend_handles:
        if isinstance(handle, PathCollection):
            y = handle.get_offset_transform().transform(handle.get_offsets())[:, 1]
            r = np.sqrt(handle.get_sizes().max()) / 2 * fig.dpi / 72
            spans.append((float(y.min() - r), float(y.max() + r)))
        else:
            box = handle.get_window_extent()
            spans.append((box.y0, box.y1))
    assert len(spans) == 7
    for upper, lower in zip(spans[:-1], spans[1:], strict=True):
        assert lower[1] <= upper[0], (upper, lower)


def test_the_predict_figure_draws_truth_and_prediction_arrows_on_one_scale(drawn, tmp_path):
    """Each panel scaled its arrows to its own largest speed, so a prediction at half the
    truth's speed drew arrows as long as the truth's; the direction error's colour scale was
    always 0-180 deg, a black panel for errors of 20 deg (figures audit, 2026-12-05)."""
    from matplotlib.collections import QuadMesh
    from matplotlib.quiver import Quiver

    kept = drawn(vd, "_save")
    offsets = np.arange(-2.0, 3.0)
    truth = np.stack([np.full((5, 5), 4.0), np.zeros((5, 5))])
    guess = np.stack([np.full((5, 5), 2.0), np.full((5, 5), 0.5)])  # 14 deg off
    metric = {"speed_error": 1.0, "direction_error_deg": 14.0, "vector_error": 1.0}
    pred = {"offsets": offsets, "position": (10.0, 10.0), "free": np.ones((5, 5), bool),
            "truth": truth, "prediction": guess, "w_up": (4.0, 0.0), "w_robot": (4.0, 0.0),
            "metrics": {"decoder": metric, "local": metric, "upstream": metric}}
    vd.plot_prediction(pred, tmp_path / "p.png")
    axes = kept[0].axes
    scales = [next(a for a in ax.get_children() if isinstance(a, Quiver)).scale
              for ax in (axes[0], axes[1])]  # truth, prediction
    assert scales[0] == scales[1]
    mesh = next(a for a in axes[3].get_children() if isinstance(a, QuadMesh))
    assert mesh.norm.vmax == pytest.approx(np.degrees(np.arctan2(0.5, 2.0)))  # 14.0 deg


def test_monte_carlo_tick_labels_within_a_decade_do_not_run_into_each_other(drawn, tmp_path):
    """Trials whose tau_drag spans about a decade (an audit's six trials, 0.27-3.48 s):
    matplotlib labelled minor ticks as 3x10^-1, 4x10^-1, ..., which overlapped (figures
    audit, 2026-12-05)."""
    import windnav.viz.ukf as vu

    kept = drawn(vu, "_save")
    rng = np.random.default_rng(0)
    spans = ([*rng.uniform(0.28, 0.9, 30), 0.952, 1.133, 3.479, 0.472, 0.842, 0.27],
             [0.2, 6.0], [0.1, 8.0], [0.05, 4.0], [0.3, 0.9])  # 1.1, 1.5, 1.9, 1.9, 0.5 decades
    for taus in spans:
        trials = [{"tau_drag": float(t), "rmse": 0.1, "params": {"mass": 0.5}} for t in taus]
        vu.plot_montecarlo({"trials": trials, "summary": {"n": len(taus), "median": 0.1},
                            "failed": 0}, tmp_path / "mc.png")
        ax = kept[-1].axes[0]
        labels = [t for t in [*ax.get_xticklabels(), *ax.get_xticklabels(minor=True)]
                  if t.get_text() and t.get_visible()
                  and ax.get_xlim()[0] <= t.get_position()[0] <= ax.get_xlim()[1]]
        boxes = sorted((t.get_window_extent() for t in labels), key=lambda b: b.x0)
        assert len(boxes) >= 2, taus
        apart = [a.x1 <= b.x0 for a, b in zip(boxes[:-1], boxes[1:], strict=True)]
        assert all(apart), [t.get_text() for t in labels]
