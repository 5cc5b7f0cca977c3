"""Animations: navigation flights over the urban wind, written as GIFs.

:func:`animate_flights` draws every vehicle of a comparison (``NavigationResult``) flying over
the wind speed, frame by frame: the recorded unsteady wind at each frame's time (or the mean),
the buildings, each vehicle's trail and position, a time label, and each vehicle's running
energy in the legend.

How it renders (measured on 2 cores, 80 frames, 432 x 389 px): ``FuncAnimation.save`` with
``PillowWriter`` redraws the whole figure twice per frame (``draw_idle``, then ``savefig`` in
``grab_frame``), axes, ticks and colour bar included: 0.17 s a draw, 27 s for the GIF. Here the
static part (axes, ticks, colour bar, start and goal) is drawn once and cached; each frame
restores it and draws only what moves (``draw_artist``: the wind image, the buildings over it,
trails, markers, legend, time), then takes the canvas's pixels. Pillow writes the GIF, as
``PillowWriter`` does, with one palette for every frame (so unchanged pixels stay identical
between frames and the GIF stores only what changed) and the wind drawn in
flat bands of 1 m/s (:data:`SPEED_LEVELS`), which compress far better than a smooth ramp: about
1-2 MB and a few seconds for the demo's GIF.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from windnav._console import closes_figures_on_error
from windnav._validate import positive_int
from windnav.viz.nav_compare import COLORS, OUTLINE, _check_results, wind_background

__all__ = ["SPEED_LEVELS", "animate_flights", "frame_times"]

SPEED_LEVELS = 16
"""Most colour bands of 1 m/s in the GIF's wind speed (bands of 2 m/s above it)."""
PALETTE_COLORS = 96
"""Colours of the GIF's one palette (of 256 possible)."""


def frame_times(results: dict, n_frames: int) -> np.ndarray:
    """``n_frames`` times from 0 to the end of the longest flight, evenly spaced, s.

    Raises
    ------
    ValueError
        ``results`` not a non-empty dict of flights, or ``n_frames`` not an integer >= 2 (0
        and 1 gave two frames; ``{}``, "max() arg is an empty sequence"; Python API audit,
        fifty-eighth session).
    """
    where = "frame_times"
    _check_results(results, where)
    try:
        enough = positive_int(n_frames, "n_frames", where) >= 2
    except ValueError:
        enough = False
    if not enough:
        raise ValueError(f"The 'n_frames' parameter of {where} must be an integer >= 2. Got "
                         f"{n_frames!r} instead.")
    end = max(float(r.t[-1]) for r in results.values())
    return np.linspace(0.0, end, int(n_frames))


def _speed_frames(flow, times: np.ndarray) -> np.ndarray:
    """Wind speed of the recorded frame at or before each time, (F, ny, nx), m/s."""
    k = np.clip(np.searchsorted(flow.t, times + 1e-9, side="right") - 1, 0, flow.t.size - 1)
    return np.hypot(flow.frames_u[k], flow.frames_v[k])


@closes_figures_on_error
def animate_flights(results: dict, city, flow, path, *, n_frames: int = 80, fps: float = 10.0,
                    unsteady: bool = True, dpi: float = 72.0, title: str = "") -> Path:
    """Write a GIF of the flights over the wind.

    Parameters
    ----------
    results : dict of str to NavigationResult
        The flights by their legend name (``"EA-MPPI+W"``), all in ``flow``'s wind.
    city : windnav.city.City
    flow : windnav.flow.FlowSolution
        The wind they flew; ``unsteady`` needs its recorded frames.
    path : str or Path
        The ``.gif`` to write.
    n_frames : int
        Frames, evenly spaced from take-off to the end of the longest flight (>= 2).
    fps : float
        Frames per second of the GIF (> 0).
    unsteady : bool
        True: the recorded wind speed at each frame's time (gusts, shedding); False: the mean.
    dpi : float
        Resolution of the 6 x 5.4 in figure, dots per inch (72: 432 x 389 px).
    title : str
        The title; the time is shown in the map's corner.

    Returns
    -------
    Path
    """
    from matplotlib.colors import BoundaryNorm
    from PIL import Image

    if isinstance(n_frames, bool) or int(n_frames) != n_frames or n_frames < 2:
        raise ValueError(f"The 'n_frames' parameter of animate_flights must be an integer >= 2. "
                         f"Got {n_frames!r} instead.")
    if not fps > 0:
        raise ValueError(f"The 'fps' parameter of animate_flights must be > 0. Got {fps!r} "
                         "instead.")
    path = Path(path)
    times = frame_times(results, int(n_frames))
    use_frames = unsteady and flow.frames_u is not None
    fluid = ~flow.solid
    speeds = _speed_frames(flow, times) if use_frames else None
    field = speeds if use_frames else np.hypot(flow.mean_u, flow.mean_v)[None]
    # flat bands of 1 m/s (2 m/s above 16 m/s) up to the 99th percentile
    top = float(np.percentile(field[:, fluid], 99))
    step = 1.0 if top <= SPEED_LEVELS else 2.0
    bounds = np.arange(0.0, step * (np.ceil(top / step) + 0.5), step)
    vmax = float(bounds[-1])

    fig, ax = plt.subplots(figsize=(6.0, 5.4), dpi=dpi)
    im = wind_background(ax, city, flow, field[0], vmax=vmax, streamlines=False)
    im.set_norm(BoundaryNorm(bounds, 256, extend="max"))
    im.set_interpolation("nearest")
    bar = fig.colorbar(im, ax=ax, shrink=0.8,
                       label="wind speed (m/s)" if use_frames else "mean wind speed (m/s)")
    bar.set_ticks(bounds[::max(1, bounds.size // 8)])
    first = next(iter(results.values()))
    ends = ax.plot(*first.start, "o", color="w", mec="k", ms=7, zorder=6)
    ends += ax.plot(*first.goal, "*", color="w", mec="k", ms=13, zorder=6)
    trails, dots = [], []
    for i, name in enumerate(results):
        c = COLORS[i % len(COLORS)]
        (line,) = ax.plot([], [], color=c, lw=1.8, zorder=5, path_effects=OUTLINE, label=name)
        (dot,) = ax.plot([], [], "o", color=c, mec="k", ms=7, zorder=7)
        trails.append(line)
        dots.append(dot)
    legend = ax.legend(loc="upper left", fontsize=8, framealpha=0.8)
    clock = ax.text(0.98, 0.02, "", transform=ax.transAxes, ha="right", va="bottom", fontsize=9,
                    bbox={"fc": "w", "alpha": 0.8, "lw": 0}, zorder=8)
    if title:
        ax.set_title(title, fontsize=10)
    buildings = list(ax.patches)
    moving = [im, *buildings, *trails, *ends, *dots, legend, clock]
    for a in moving:
        a.set_animated(True)
    fig.tight_layout()
    canvas = fig.canvas
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    # index of each frame's time in each flight (its last sample once it has ended)
    index = [np.minimum(np.searchsorted(r.t, times + 1e-9, side="right") - 1, r.t.size - 1)
             for r in results.values()]

    frames = []
    for f in range(times.size):
        canvas.restore_region(background)
        if use_frames:
            im.set_data(np.ma.masked_array(speeds[f], flow.solid))
        for j, (name, r) in enumerate(results.items()):
            k = int(index[j][f])
            trails[j].set_data(r.position[:k + 1, 0], r.position[:k + 1, 1])
            dots[j].set_data(r.position[k:k + 1, 0], r.position[k:k + 1, 1])
            state = r.outcome if k == r.t.size - 1 else "flying"
            legend.get_texts()[j].set_text(f"{name}: {r.energy[k] / 1e3:.2f} kJ, {state}")
        clock.set_text(f"t = {times[f]:5.1f} s")
        for a in moving:
            ax.draw_artist(a)
        frames.append(Image.fromarray(np.asarray(canvas.buffer_rgba())[..., :3].copy()))
    plt.close(fig)

    # one palette, from a strip of the first, middle and last frames (every wind band, trail
    # and legend colour appears in one of them)
    w, h = frames[0].size
    strip = Image.new("RGB", (w, 3 * h))
    for i, fr in enumerate((frames[0], frames[len(frames) // 2], frames[-1])):
        strip.paste(fr, (0, i * h))
    palette = strip.quantize(colors=PALETTE_COLORS, method=Image.Quantize.MEDIANCUT)
    frames = [fr.quantize(palette=palette, dither=Image.Dither.NONE) for fr in frames]
    path.parent.mkdir(parents=True, exist_ok=True)
    frames[0].save(path, format="GIF", save_all=True, append_images=frames[1:],
                   duration=int(round(1000.0 / fps)), loop=0, optimize=False)
    return path
