"""Objects keep their own copies of what they are given, and results are the caller's.

An input-mutation audit (thirty-seventh session) found classes that kept a reference to the
caller's array, so that a caller refilling one buffer (a loop's usual pattern) changed an
object already built, and results that were the object's own state. Each test below fails
on the code before that audit.
"""

from __future__ import annotations

import numpy as np
import pytest

import windnav as wn
from windnav.estimate import UKF, WindUKF, merwe_weights, robust_cholesky, ukf_update
from windnav.plan import LocalWind, MPPIPlanner, planner_config
from windnav.vehicle import Multirotor, VehicleState, params


def test_wind_ukf_differences_a_copy_of_the_odometry():
    """A caller refilling one buffer each step: the 'previous' sample must not be this one."""
    p = params("hummingbird")
    dt, steps = 0.01, 200
    vel = np.zeros((steps, 3))
    vel[:, 0] = 0.5 * np.arange(steps) * dt  # accelerating at 0.5 m/s^2
    odom = np.concatenate([vel, np.zeros((steps, 3))], axis=1)
    u = np.full(4, p.hover_rotor_speed)

    def run(reuse: bool):
        f = WindUKF(p, dt, accel_from_odometry=True)
        buf = np.empty(6)
        for k in range(steps):
            if reuse:
                buf[:] = odom[k]
            z = buf if reuse else odom[k].copy()
            est = f.step(u, {"odom": z, "gyro": np.zeros(3), "rotor_speeds": u})
        return est.wind_world

    np.testing.assert_array_equal(run(True), run(False))


def test_winds_keep_their_own_parameters():
    mean = np.array([3.0, 0.0, 0.0])
    sigma = np.array([1.5, 1.5, 0.7])
    gust = wn.wind.DrydenWind(mean=mean, sigma=sigma, rng=0)
    reference = wn.wind.DrydenWind(mean=(3.0, 0.0, 0.0), sigma=(1.5, 1.5, 0.7), rng=0)
    gust.velocity(0.5, [[0.0, 0.0, 0.0]])
    mean[0], sigma[0] = 10.0, 5.0
    for t in (0.5, 50.0):
        np.testing.assert_array_equal(gust.velocity(t, [[0.0, 0.0, 0.0]]),
                                      reference.velocity(t, [[0.0, 0.0, 0.0]]))
    np.testing.assert_array_equal(gust.mean, [3.0, 0.0, 0.0])
    np.testing.assert_array_equal(gust.sigma, [1.5, 1.5, 0.7])

    v = np.array([2.0, 1.0, 0.0])
    const = wn.wind.ConstantWind(v)
    v[0] = 99.0
    np.testing.assert_array_equal(const.velocity(0.0, [[0.0, 0.0, 0.0]])[0], [2.0, 1.0, 0.0])
    assert not const.mean.flags.writeable


def test_gridded_wind_copies_its_axes_and_leaves_the_callers_flags():
    base = np.arange(8.0)
    x = base[:4]  # a view of a writable array
    y = np.arange(4.0)
    t = np.array([0.0, 1.0])
    u = np.tile(x, (2, 4, 1))
    w = wn.wind.GriddedWind(x, y, u, np.zeros_like(u), t=t)
    assert x.flags.writeable and y.flags.writeable and t.flags.writeable
    before = w.velocity(0.5, [[1.5, 2.0, 10.0]])
    base[:4] *= 0.5
    y += 100.0
    t += 100.0
    np.testing.assert_array_equal(w.velocity(0.5, [[1.5, 2.0, 10.0]]), before)
    np.testing.assert_array_equal(before[0], [1.5, 0.0, 0.0])


def test_mean_field_keeps_its_own_inlet():
    city = wn.city.City((0, 60, 0, 40), [[20, 28, 15, 25]], [10.0])
    x, y = np.arange(0.5, 60.0), np.arange(0.5, 40.0)
    zero = np.zeros((y.size, x.size))
    solid = np.zeros((y.size, x.size), dtype=bool)
    w_up = np.empty(2)
    fields = []
    for d in (0.0, 90.0):
        w_up[:] = 5.0 * np.array([np.cos(np.radians(d)), np.sin(np.radians(d))])
        fields.append(wn.predict.MeanField(city, x, y, zero, zero, solid, w_up))
    np.testing.assert_array_equal(fields[0].w_up, [5.0, 0.0])
    assert fields[1].w_up[1] == 5.0


def _planner_and_problem():
    p = params("hummingbird")
    cfg = planner_config(p, "ea-mppi-w", horizon=25.0)
    city = wn.city.City((0, 400, 0, 400), [[150, 170, 150, 250]], [20.0])
    planner = MPPIPlanner(cfg, (350.0, 300.0), rng=0)
    xy = np.array([100.0, 200.0])
    scan = city.lidar(xy[None], n_rays=360, max_range=100.0)[0]
    return planner, xy, scan


def test_mppi_plan_is_the_callers_to_keep():
    planner, xy, scan = _planner_and_problem()
    planner.update([*xy, 0.5, -0.2], scan, LocalWind.uniform((2.0, 1.0)))
    first = planner.plan()
    end = first.positions[-1].copy()
    first.controls[...] = 5.0
    first.cost_parts[...] = -1.0
    again = planner.plan()
    np.testing.assert_array_equal(again.positions[-1], end)
    assert not np.any(again.cost_parts == -1.0)


def test_local_wind_grid_copies_the_callers_buffer():
    planner, xy, scan = _planner_and_problem()
    offsets = np.arange(-12.0, 13.0)
    uv = np.empty((2, 25, 25))
    uv[0], uv[1] = 3.0, -1.0
    known = LocalWind.grid(uv, offsets)
    planner.update([*xy, 0.5, -0.2], scan, known)
    end = planner.plan().positions[-1].copy()
    uv[...] = -uv
    offsets += 50.0
    np.testing.assert_array_equal(planner.plan().positions[-1], end)
    assert known.uv[0, 0, 0] == 3.0 and known.x[0] == -12.0
    # copy=False adopts the array (the closed loop's own whole-map field)
    adopted = LocalWind.grid(uv, np.arange(-12.0, 13.0), copy=False)
    assert np.shares_memory(adopted.uv, uv)


def test_decoder_keeps_read_only_copies_of_its_weights():
    dec = wn.predict.load_decoder()
    weights = {k: v.copy() for k, v in dec.weights.items()}
    mine = wn.predict.Decoder(weights, dec.metadata)
    scans = np.full((1, 360), 100.0)  # an open square: every ray a miss
    before = mine.predict(scans, [[4.0, 1.5]], [[1.0, 0.5]])
    for v in weights.values():
        v *= 1.5
    np.testing.assert_array_equal(mine.predict(scans, [[4.0, 1.5]], [[1.0, 0.5]]), before)
    for name, v in mine.weights.items():
        assert not v.flags.writeable, name  # an edit would reach some layers and not others


def test_ukf_update_result_is_not_the_filter_state():
    n = 3
    eye = np.eye(n)
    H = np.eye(2, n)
    k = UKF(lambda X, dt, u: X, np.zeros(n), eye, 0.01 * eye, dt=0.1,
            blocks={"h": (lambda X: X @ H.T, 0.1 * np.eye(2))})
    res = k.update({"h": np.ones(2)})
    x, P = k.x.copy(), k.P.copy()
    res.x[...] = 1e9
    res.P[...] = 1e9
    np.testing.assert_array_equal(k.x, x)
    np.testing.assert_array_equal(k.P, P)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_float32_inputs_compute_in_float64(dtype):
    """float32 arrays are the values they hold, computed at the physics' float64 precision."""
    n = 3
    H = np.eye(2, n)
    args = (np.ones(2), lambda X: X @ H.T, 0.1 * np.eye(2), merwe_weights(n))
    got = ukf_update(np.zeros(n, dtype), np.eye(n, dtype=dtype), *args)
    want = ukf_update(np.zeros(n), np.eye(n), *args)
    np.testing.assert_array_equal(got.x, want.x)
    assert got.x.dtype == np.float64

    bad = np.array([[1.0, 2.0], [2.0, 1.0]], dtype=dtype)  # indefinite: repaired
    L, _, repaired = robust_cholesky(bad)
    assert repaired and L.dtype == np.float64
    np.testing.assert_array_equal(L, robust_cholesky(bad.astype(np.float64))[0])

    p = params("hummingbird")
    m = Multirotor(p)
    s = m.hover_state(np.array([[300.123, 200.456, 50.789]]))
    fields = (s.position, s.velocity, s.attitude, s.body_rates, s.rotor_speeds)
    s_typed = VehicleState(*(a.astype(dtype) for a in fields))
    s_64 = VehicleState(*(a.astype(dtype).astype(np.float64) for a in fields))
    cmd, wind = np.full((1, 4), 480.0), np.array([3.0, 0.0, 0.0])
    a, b = m.step(s_typed, cmd, wind, 0.01), m.step(s_64, cmd, wind, 0.01)
    assert a.position.dtype == np.float64
    np.testing.assert_array_equal(a.position, b.position)

    c = wn.control.SE3Controller(p)
    x = s_typed.to_array()
    target = np.array([[301.0, 200.0, 51.0]], dtype=dtype)
    zero = np.zeros((1, 3), dtype=dtype)
    yaw = np.zeros(1, dtype=dtype)
    got_cmd, _ = c.track(x.astype(dtype), target, zero, zero, yaw, yaw)
    want_cmd, _ = c.track(x.astype(dtype).astype(np.float64), target.astype(np.float64),
                          zero.astype(np.float64), zero.astype(np.float64),
                          yaw.astype(np.float64), yaw.astype(np.float64))
    np.testing.assert_array_equal(got_cmd, want_cmd)


def test_hand_built_containers_hold_float64():
    """``ReachLattice``, the sysid ``Table`` and ``FlightSamples``, built by hand from float32
    arrays, held them as float32 and computed on them in float32 (last bits, 5e-8 relative:
    the thirty-seventh session's aliasing audit, left then). float64 now, the same values."""
    from windnav.plan.reach import ReachLattice
    from windnav.sysid.io import Table
    from windnav.sysid.unsteadiness import FlightSamples

    f32 = np.linspace(0.1, 1.3, 6, dtype=np.float32)
    lat = ReachLattice(x=f32, y=f32, free=np.ones((6, 6), bool),
                       frames=np.zeros((1, 6, 6, 2), np.float32), t0=0.0, dt_frames=1.0,
                       dx=0.24, clearance=1.0, gust=np.zeros((6, 6, 3), np.float32))
    table = Table("by hand", {"t": f32, "thrust": 2 * f32})
    samples = FlightSamples(*(np.tile(f32[:, None], (1, k)) for k in (2, 2, 2, 3)))
    arrays = [lat.x, lat.y, lat.frames, lat.gust, *table.columns.values(), samples.xy,
              samples.wind_xy, samples.force_cmd_xy, samples.body_rates]
    assert all(a.dtype == np.float64 for a in arrays)
    np.testing.assert_array_equal(table.columns["t"], f32.astype(np.float64))
    assert lat.free.dtype == bool


# ---------------------------------------------------------------- pickling and copies


def test_filters_pickle_and_continue_bitwise():
    """``WindUKF`` built closures and ``UKF`` cached one after a joint update of two blocks:
    neither pickled (a spawned worker, ``ProcessPoolExecutor``)."""
    import pickle

    p = params("hummingbird")
    f = WindUKF(p, 0.01)
    u = np.full(4, p.hover_rotor_speed)
    meas = {"gyro": np.zeros(3), "rotor_speeds": u, "accel": np.array([0.1, 0.0, 9.81])}
    f.step(u, meas)  # a joint update of three blocks
    g = pickle.loads(pickle.dumps(f))
    for _ in range(3):
        a, b = f.step(u, meas), g.step(u, meas)
    np.testing.assert_array_equal(a.wind_world, b.wind_world)
    np.testing.assert_array_equal(f.P, g.P)


def test_copies_keep_their_arrays_read_only():
    """NumPy restores arrays writable: a copy lost the protection of its class, and a copied
    ``FlowSolution`` took NaN frames past the finite check it had passed."""
    import copy
    import pickle

    city = wn.city.City((0, 60, 0, 40), [[20, 28, 15, 25]], [10.0])
    sol = wn.flow.simulate(city, speed=5.0, dx=1.0, dt=0.1, spinup_steps=5, steps=10,
                           record_every=5)
    objects = {
        "City.footprints": (city, lambda o: o.footprints),
        "FlowSolution.frames_u": (sol, lambda o: o.frames_u),
        "MultirotorParams.inertia": (params("hummingbird"), lambda o: o.inertia),
        "Decoder.weights": (wn.predict.load_decoder(), lambda o: o.weights["coeff.weight"]),
        "GriddedWind.x": (sol.wind_field(), lambda o: o.x),
        "ConstantWind.mean": (wn.wind.ConstantWind((1.0, 2.0, 0.0)), lambda o: o.mean),
        "DrydenWind.mean": (wn.wind.DrydenWind(mean=(3, 0, 0), sigma=(1, 1, 1), rng=0),
                            lambda o: o.mean),
    }
    for name, (obj, get) in objects.items():
        assert not get(obj).flags.writeable, name
        for how, clone in (("pickle", pickle.loads(pickle.dumps(obj))),
                           ("deepcopy", copy.deepcopy(obj))):
            assert not get(clone).flags.writeable, (name, how)
            np.testing.assert_array_equal(get(clone), get(obj))


def test_frame_buffers_hand_a_block_to_one_thread_only(monkeypatch):
    """Between finding a free block and handing it out nothing held other threads off: two
    threads could get one block, and two runs write their frames into the same memory."""
    import threading
    import time

    from windnav.flow import FrameBuffers

    pool = FrameBuffers()
    held = [pool.take((4, 4)) for _ in range(4)]
    del held  # four free blocks, their arrays gone
    slow_check = FrameBuffers._is_free

    def is_free(entry):  # widen the window between the check and the hand-out
        free = slow_check(entry)
        time.sleep(0.002)
        return free

    monkeypatch.setattr(FrameBuffers, "_is_free", staticmethod(is_free))
    taken = [None] * 4
    start = threading.Barrier(4)

    def take(i):
        start.wait()
        taken[i] = pool.take((4, 4))

    threads = [threading.Thread(target=take, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    addresses = {a.__array_interface__["data"][0] for a in taken}
    assert len(addresses) == 4


# ------------------------------------------- the experiments layer, sysid and observability


def test_decoder_offsets_are_read_only_and_the_onboard_stack_keeps_its_own():
    """The onboard stack places its field by ``decoder.offsets``, and ``navigate`` shares one
    decoder per process: an in-place edit moved every later flight's wind."""
    from windnav.experiments.onboard import OnboardStack

    dec = wn.predict.load_decoder()
    assert not dec.offsets.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        dec.offsets += 10.0
    p = params("hummingbird")
    city = wn.city.City((0, 100, 0, 100), [[40, 60, 40, 60]], [20.0])
    stack = OnboardStack(city, Multirotor(p), p, speed=5.0, direction_deg=0.0,
                         control_rate_hz=100.0, plan_rate_hz=10.0, n_max=10,
                         rng=np.random.default_rng(0), decoder=dec)
    assert not np.shares_memory(stack.offsets, dec.offsets)


def test_aero_data_keeps_what_it_checked():
    """``AeroData`` is checked finite at construction; a caller refilling its buffer got NaN
    into ``fit_aero`` (a NaN fit, no error), and ``to_columns`` handed out its own arrays."""
    from windnav.sysid import AeroData

    k = 50
    rng = np.random.default_rng(0)
    t = np.arange(k) * 0.1
    va = rng.normal(size=(k, 3))
    f = rng.normal(size=(k, 3)) + [0.0, 0.0, 9.81]
    eta = 400.0 + rng.normal(size=(k, 4))
    data = AeroData(t, va, f, eta)
    f[:] = np.nan
    assert np.isfinite(data.specific_force_body).all()
    with pytest.raises(ValueError, match="read-only"):
        data.to_columns()["time_s"][:] = -1.0


def test_escapes_keep_their_own_route_and_goal():
    from windnav.plan import EscapeConfig, FastestEscape, RouteEscape

    route = np.column_stack([np.linspace(0.0, 100.0, 11), np.zeros(11)])
    escape = RouteEscape(route, (100.0, 0.0))
    route[:, 1] = 50.0
    np.testing.assert_array_equal(escape.samples[:, 1], 0.0)
    assert escape.length == 100.0
    goal = np.array([100.0, 0.0])
    fastest = FastestEscape(lambda p: None, goal, EscapeConfig(airspeed_mps=10.0,
                                                               pace_margin_s=5.0),
                            deadline_s=30.0)
    goal[:] = 0.0
    np.testing.assert_array_equal(fastest.goal, [100.0, 0.0])
    np.testing.assert_array_equal(fastest.goal, fastest.monitor.goal)


def test_observability_matrix_is_the_callers():
    from windnav.estimate.observability import observability_matrix

    p = params("hummingbird")
    x = np.zeros(12 + p.n_rotors)
    x[12:] = p.hover_rotor_speed
    O = observability_matrix(p, x, order=1)
    O *= 2.0  # was a read-only broadcast view
    np.testing.assert_array_equal(O, 2.0 * observability_matrix(p, x, order=1))
