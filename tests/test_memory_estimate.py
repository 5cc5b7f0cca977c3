"""Memory is estimated before a flow run allocates, and a run that cannot fit is refused.

The estimate is checked against the peak resident memory of real runs measured in a fresh
process (the kernel's high-water mark ``VmHWM``, reset through ``/proc/self/clear_refs``).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
import tracemalloc

import pytest
from test_wind_dataset import MAPS, SETTINGS, FakeSolver

from windnav.city import City, grid_shape
from windnav.experiments.wind_sweep import sweep
from windnav.flow import simulate, simulate_batch
from windnav.flow.memory import (
    ENV_VAR,
    MemoryEstimateError,
    check_flow_memory,
    default_memory_limit,
    estimate_flow_memory,
    fluid_fraction,
    parse_bytes,
)


def city_of(size_m: float) -> City:
    """A square map with a lattice of blocks over about a tenth of its area."""
    s = size_m / 8
    blocks = [[i * s + 0.25 * s, i * s + 0.75 * s, j * s + 0.25 * s, j * s + 0.75 * s]
              for i in range(8) for j in range(8) if (i + j) % 3 == 0]
    return City((0.0, size_m, 0.0, size_m), blocks, [10.0] * len(blocks))


def test_a_20_km_map_at_1_m_is_refused_before_anything_is_allocated():
    city = city_of(20_000.0)
    tracemalloc.start()
    try:
        with pytest.raises(MemoryEstimateError) as err:
            simulate_batch(city, [2.0, 5.0], 0.0, dx=1.0, dt=0.1, memory_limit=16e9)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 20e6  # one float64 field of this grid alone is 3.2 GB
    msg = str(err.value)
    need = estimate_flow_memory((20_000, 20_000), 2, fluid_fraction=fluid_fraction(city))
    assert need > 5e11  # the factorisation of 4e8 cells: hundreds of GB
    assert "simulate_batch" in msg and "20000 x 20000" in msg and "16 GB" in msg
    assert f"{need / 1e9:.3g} GB" in msg
    assert "'memory_limit'" in msg and ENV_VAR in msg and "--" not in msg
    assert isinstance(err.value, ValueError)


def test_simulate_uses_the_default_limit_from_the_environment(monkeypatch):
    monkeypatch.setenv(ENV_VAR, "2G")
    assert default_memory_limit() == 2_000_000_000
    with pytest.raises(MemoryEstimateError, match=rf"simulate: .*2 GB \(set by {ENV_VAR}\)"):
        simulate(city_of(5_000.0), speed=3.0, dx=1.0, dt=0.1, steps=1)


def test_a_small_map_runs_and_the_limit_is_the_estimate():
    city = city_of(160.0)
    sol = simulate_batch(city, [2.0], 0.0, dx=2.0, dt=0.2, spinup_steps=0, steps=2,
                         memory_limit=1e9)[0]
    assert sol.mean_u.shape == (80, 80)
    need = estimate_flow_memory(grid_shape(city.bounds, 2.0), 1,
                                fluid_fraction=fluid_fraction(city))
    assert check_flow_memory((80, 80), fluid_fraction=fluid_fraction(city),
                             memory_limit=need) == need
    with pytest.raises(MemoryEstimateError):
        simulate_batch(city, [2.0], 0.0, dx=2.0, dt=0.2, steps=2, memory_limit=need - 1)


def test_the_estimate_counts_speeds_and_frames_and_the_open_area():
    base = estimate_flow_memory((300, 300))
    per_speed = estimate_flow_memory((300, 300), n_speeds=2) - base
    assert estimate_flow_memory((300, 300), n_speeds=4) - base == pytest.approx(3 * per_speed)
    frames = estimate_flow_memory((300, 300), n_frames=100) - base
    assert frames == pytest.approx(300 * 300 * 16 * 100)  # u and v in float64 per frame
    assert estimate_flow_memory((300, 300), fluid_fraction=0.5) < base
    assert estimate_flow_memory((300, 300), pressure="jacobi") < base / 3
    city = city_of(800.0)  # blocks of a quarter of a lattice cell
    assert fluid_fraction(city) == pytest.approx(1 - len(city.footprints) / 4 / 64, abs=0.01)


MEASURE = textwrap.dedent("""
    import json, re, sys
    sys.path.insert(0, {here!r})
    from test_memory_estimate import city_of
    from windnav.flow import simulate_batch

    def status(key):
        text = open("/proc/self/status").read()
        return int(re.search(key + r":\\s+(\\d+) kB", text).group(1)) * 1024

    simulate_batch(city_of(20.0), [2.0], 0.0, dx=1.0, dt=0.1, spinup_steps=0, steps=2)
    before = status("VmRSS")
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")  # resets the peak resident size (VmHWM) to the current one
    n, speeds, frames = {n}, {speeds}, {frames}
    simulate_batch(city_of(float(n)), [2.0 + s for s in range(speeds)], 30.0, dx=1.0,
                   dt=0.25, spinup_steps=0, steps=max(2, frames),
                   record_every=1 if frames else 0)
    print(json.dumps(status("VmHWM") - before))
""")


@pytest.mark.parametrize("n, speeds, frames", [(300, 1, 0), (250, 2, 10)])
def test_the_estimate_is_within_a_factor_1_5_of_the_measured_peak(n, speeds, frames):
    if not sys.platform.startswith("linux") or not os.access("/proc/self/clear_refs", os.W_OK):
        pytest.skip("needs Linux's /proc/self/clear_refs to measure the peak resident memory")
    here = os.path.dirname(os.path.abspath(__file__))
    script = MEASURE.format(here=here, n=n, speeds=speeds, frames=frames)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    measured = json.loads(done.stdout.strip().splitlines()[-1])
    city = city_of(float(n))
    estimate = estimate_flow_memory((n, n), speeds, frames, fluid_fraction=fluid_fraction(city))
    assert measured > 10e6  # a real measurement, not a reused heap
    assert 1 / 1.5 <= estimate / measured <= 1.5, (estimate, measured)


def test_a_sweep_that_cannot_fit_is_refused_before_the_store_is_created(tmp_path):
    big = [("big", "big.json", city_of(20_000.0))]
    with pytest.raises(MemoryEstimateError, match=r"sweep: map 1 \('big', 20000 x 20000"):
        sweep(MAPS[:1] + big, tmp_path / "s.zarr", speeds=[2.0], directions_deg=[0.0],
              settings={**SETTINGS, "dx": 1.0}, backend="serial", progress=False,
              memory_limit=8e9)
    assert not (tmp_path / "s.zarr").exists()


def test_a_sweep_runs_fewer_process_workers_when_the_limit_holds_fewer(tmp_path):
    (tmp_path / "log").mkdir()
    fake = FakeSolver(str(tmp_path / "log"))
    with pytest.warns(UserWarning, match="running 1 worker"):
        store, results = sweep(MAPS, tmp_path / "s.zarr", speeds=[2.0], directions_deg=[0.0],
                               settings=SETTINGS, backend="process", workers=2, progress=False,
                               simulate=fake, memory_limit=300e6)
    assert all(r.ok for r in results) and len(results) == 2
    assert len({r.value["map_index"] for r in results}) == 2


def test_bad_limits_are_named():
    with pytest.raises(ValueError, match="'memory_limit' parameter of simulate_batch"):
        simulate_batch(city_of(160.0), [2.0], dx=2.0, dt=0.2, steps=1, memory_limit=-1)
    assert parse_bytes("1.5GiB") == int(1.5 * 2**30) and parse_bytes("8e9") == 8_000_000_000
    assert parse_bytes("512 MB") == 512_000_000
    with pytest.raises(ValueError, match=ENV_VAR):
        parse_bytes("lots")
