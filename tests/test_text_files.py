"""Text inputs written with a UTF-8 byte-order mark (Excel's "CSV UTF-8", some editors) read
as without it; every one was refused ('\\ufefftimestamp' is no column; files audit)."""

from __future__ import annotations

import numpy as np
import pytest

from windnav.city import City
from windnav.commands.benchmark_nav import scenario_ids
from windnav.predict.train import RECIPES, load_recipe
from windnav.sysid import read_table

BOM = b"\xef\xbb\xbf"


def test_a_csv_with_a_byte_order_mark(tmp_path):
    (tmp_path / "a.csv").write_bytes(BOM + b"timestamp,rpm\n0.0,100\n0.1,200\n")
    tab = read_table(tmp_path / "a.csv")
    assert tab.names == ["timestamp", "rpm"]
    np.testing.assert_array_equal(tab.columns["rpm"], [100.0, 200.0])


def test_a_city_json_with_a_byte_order_mark(tmp_path):
    city = City((0.0, 100.0, 0.0, 100.0), np.array([[10.0, 20.0, 10.0, 30.0]]), np.array([5.0]))
    city.to_rotorpy_json(tmp_path / "c.json")
    (tmp_path / "bom.json").write_bytes(BOM + (tmp_path / "c.json").read_bytes())
    again = City.from_rotorpy_json(tmp_path / "bom.json")
    np.testing.assert_array_equal(again.footprints, city.footprints)


def test_a_recipe_with_a_byte_order_mark(tmp_path):
    (tmp_path / "r.toml").write_bytes(BOM + (RECIPES / "tiny.toml").read_bytes())
    (tmp_path / "default.toml").write_bytes((RECIPES / "default.toml").read_bytes())  # its base
    mine, shipped = load_recipe(tmp_path / "r.toml"), load_recipe(RECIPES / "tiny.toml")
    assert {k: v for k, v in mine.items() if k != "source"} == {
        k: v for k, v in shipped.items() if k != "source"}


def test_a_scenario_list_with_a_byte_order_mark_or_not_text(tmp_path):
    from test_nav_benchmark import TINY

    (tmp_path / "ids.txt").write_bytes(BOM + b"tiny/m00/w00/p0\n# a comment\ntiny/m00/w01/p1\n")
    assert scenario_ids(str(tmp_path / "ids.txt"), TINY, "windnav x") == frozenset(
        {"tiny/m00/w00/p0", "tiny/m00/w01/p1"})
    (tmp_path / "bin.txt").write_bytes(b"\xff\xfe\x00tiny")
    with pytest.raises(ValueError, match="'--scenarios' parameter of windnav x .*not UTF-8"):
        scenario_ids(str(tmp_path / "bin.txt"), TINY, "windnav x")
