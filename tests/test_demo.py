"""The end-to-end demo runs, writes its figures, and the Wind UKF tracks the urban wind."""

import json

from windnav.cli import main


def test_demo_end_to_end(tmp_path):
    js = tmp_path / "demo.json"
    assert main(["demo", "--seed", "1", "--out", str(tmp_path / "run"), "--json", str(js)]) == 0
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert json.loads(js.read_text()) == summary and summary["command"] == "windnav demo"
    assert summary["config"]["flow_dt"] == 0.2  # 5 m/s on 2 m cells: CFL 0.5, the default step
    for name in ("map_wind_path.png", "wind_estimate.png"):
        assert (tmp_path / "run" / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert summary["samples_inside_buildings"] == 0
    assert summary["rotor_saturation_fraction"] == 0.0
    # the wind varies along the route, and the filter follows it
    assert summary["max_wind_speed_along_path_m_s"] > 1.5 * summary["inlet_speed_m_s"]
    assert summary["wind_rmse_m_s"] < 0.6
    assert summary["filter_covariance_repairs"] == 0
