"""Reading system-identification data: CSV and whitespace tables, FlightLogs, ROS bags.

Every reader returns a :class:`Table` (named float64 columns plus the file they came from), so
every fit reports a bad input by file and column. The table formats are:

- **CSV with a header line** (comma separated), e.g. the thrust-stand log
  ``timestamp,pwm,thrust_N,torque_Nm,rpm,voltage_V,current_A``.
- **Headerless whitespace tables** (the ``optimal_energy_quad`` flight logs): columns are
  named by their 0-based index (``"0"``, ``"1"``, ...) or by a named layout
  (:data:`LAYOUTS`).
- **ROS 1 and ROS 2 bags** (:func:`read_bag`, through the optional pure-Python ``rosbags``
  package), with a topic map ``{column: "/topic:field.path"}``.

Empty fields and ``nan`` read as NaN (the fits drop such rows and say how many); any other
value that is not a number is an error naming the file, the line and the column.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["LAYOUTS", "OPTIMAL_ENERGY_QUAD", "Table", "parse_topic_map", "read_bag",
           "read_table", "write_csv"]


OPTIMAL_ENERGY_QUAD = (
    "mass_g", "time_s", "longitude_deg", "latitude_deg", "altitude_gps_m", "altitude_m",
    "horizontal_speed_m_s", "speed_m_s", "vertical_speed_m_s", "voltage_V", "current_A",
    "power_W", "roll_deg", "pitch_deg", "heading_deg",
    "pwm_1_us", "pwm_2_us", "pwm_3_us", "pwm_4_us", "rpm_1", "rpm_2", "rpm_3", "rpm_4",
    "rpm_mean", "body_rate_x", "body_rate_y", "body_rate_z", "column_27",
    "accel_x_m_s2", "accel_y_m_s2", "accel_z_m_s2", "column_31", "column_32", "column_33",
    "rpm_rate_1", "rpm_rate_2", "rpm_rate_3", "rpm_rate_4", "rpm_rate_mean",
)
"""Column names of the 39-column flight logs of spencerfolk/optimal_energy_quad (e.g.
``12in_data_long_cruise_heavy.txt``). The files carry no header; these names are inferred from
the values (``docs/sysid.md`` gives the evidence); ``column_NN`` are not identified."""

LAYOUTS = {"optimal_energy_quad": OPTIMAL_ENERGY_QUAD}
"""Named column layouts of headerless tables (``--layout`` of the commands)."""


@dataclass(frozen=True, eq=False)
class Table:
    """Named columns of numbers read from one file.

    Attributes
    ----------
    source : str
        The file (as given), for messages.
    columns : dict of str to ndarray of shape (n,)
        float64 columns, all of the same length, in file order.
    """

    source: str
    columns: dict

    def __post_init__(self):
        # float64 columns, as read_table gives them, also for a table built by hand from float32
        object.__setattr__(self, "columns", {k: np.asarray(v, dtype=np.float64)
                                             for k, v in self.columns.items()})

    def __len__(self) -> int:
        return len(next(iter(self.columns.values()))) if self.columns else 0

    @property
    def names(self) -> list[str]:
        """Column names, in file order."""
        return list(self.columns)

    def require(self, names: Sequence[str], where: str) -> None:
        """Raise a ValueError naming the file and every missing column of ``names``."""
        missing = [n for n in names if n not in self.columns]
        if missing:
            raise ValueError(
                f"The file {self.source!r} given to {where} lacks the column(s) {missing}; it "
                f"has {self.names}.")

    def column(self, name: str, where: str) -> np.ndarray:
        """The column ``name`` (float64), or a ValueError naming the file and the column."""
        self.require([name], where)
        return self.columns[name]

    def select(self, mask) -> Table:
        """The rows where ``mask`` is True."""
        mask = np.asarray(mask, dtype=bool)
        return Table(self.source, {k: v[mask] for k, v in self.columns.items()})


def _number(text: str, source: str, line: int, name: str) -> float:
    s = text.strip()
    if s == "" or s.lower() in ("nan", "-nan", "+nan"):
        return math.nan
    try:
        return float(s)
    except ValueError:
        raise ValueError(f"The file {source!r} holds {text!r} in column {name!r} at line "
                         f"{line}, which is not a number.") from None


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def read_table(path, *, layout: str | Sequence[str] | None = None,
               where: str = "read_table") -> Table:
    """Read a CSV file with a header line, or a headerless whitespace/CSV table.

    Parameters
    ----------
    path : str or path-like
    layout : str or sequence of str, optional
        Names of the columns of a headerless file: a key of :data:`LAYOUTS` or the names
        themselves. Without it a headerless file's columns are named ``"0"``, ``"1"``, ...
    where : str
        The caller, for messages.

    Returns
    -------
    Table

    Raises
    ------
    ValueError
        Naming the file (and the line and column): a missing or empty file, a row of the
        wrong length, a value that is not a number, a layout that does not fit.
    """
    path = Path(path)
    source = str(path)
    if not path.is_file():
        raise ValueError(f"The file {source!r} given to {where} does not exist (or is not a "
                         "file).")
    text = path.read_text(encoding="utf-8-sig", errors="replace").splitlines()  # BOM: Excel
    lines = [(i + 1, ln) for i, ln in enumerate(text) if ln.strip() and not ln.startswith("#")]
    if not lines:
        raise ValueError(f"The file {source!r} given to {where} is empty.")
    comma = "," in lines[0][1]

    def split(line: str) -> list[str]:
        return next(csv.reader([line])) if comma else line.split()

    first = [f.strip() for f in split(lines[0][1])]
    header = not all(_is_number(f) or f.lower() in ("", "nan") for f in first)
    if isinstance(layout, str):
        if layout not in LAYOUTS:
            raise ValueError(f"The 'layout' parameter of {where} must be one of "
                             f"{list(LAYOUTS)}. Got {layout!r} instead.")
        layout = LAYOUTS[layout]
    if header:
        if layout is not None:
            raise ValueError(f"The file {source!r} given to {where} has a header line; a "
                             "column layout is only for headerless files.")
        names, rows = first, lines[1:]
    else:
        names = list(layout) if layout is not None else [str(i) for i in range(len(first))]
        rows = lines
        if len(names) != len(first):
            raise ValueError(f"The file {source!r} given to {where} has {len(first)} columns "
                             f"but the layout names {len(names)}.")
    if len(set(names)) != len(names):
        raise ValueError(f"The file {source!r} given to {where} repeats a column name in "
                         f"{names}.")
    values = np.empty((len(rows), len(names)))
    for r, (lineno, line) in enumerate(rows):
        fields = split(line)
        if len(fields) != len(names):
            raise ValueError(f"The file {source!r} given to {where} has {len(fields)} fields "
                             f"at line {lineno}; its header names {len(names)} columns.")
        values[r] = [_number(f, source, lineno, n) for f, n in zip(fields, names, strict=True)]
    return Table(source, {n: values[:, j].copy() for j, n in enumerate(names)})


def write_csv(path, columns: Mapping[str, np.ndarray], *, fmt: str = "%.10g") -> Path:
    """Write equal-length ``columns`` as a CSV file with a header line; returns the path."""
    path = Path(path)
    names = list(columns)
    data = np.column_stack([np.asarray(columns[n], dtype=np.float64) for n in names])
    np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt=fmt)
    return path


# ------------------------------------------------------------------------------ ROS bags


def parse_topic_map(items: Sequence[str], where: str) -> dict[str, tuple[str, str]]:
    """Parse ``["column=/topic:field.path", ...]`` into ``{column: (topic, field_path)}``.

    The field path is optional (``column=/topic``: the whole message, e.g. a
    ``std_msgs/Float64``'s ``data``). The order is kept: the first entry's topic is the time
    base of :func:`read_bag`.
    """
    out: dict[str, tuple[str, str]] = {}
    for item in items:
        name, sep, spec = str(item).partition("=")
        topic, _, field = spec.partition(":")
        if not sep or not name or not topic.startswith("/"):
            raise ValueError(f"The '--topic' parameter of {where} must read "
                             f"COLUMN=/topic[:field.path]. Got {item!r} instead.")
        if name in out:
            raise ValueError(f"The '--topic' parameter of {where} maps {name!r} twice.")
        out[name] = (topic, field)
    return out


def _components(value, topic: str, field: str) -> tuple[list[float], tuple[str, ...]]:
    """Numbers of a message field and the suffixes of their columns."""
    if hasattr(value, "x") and hasattr(value, "y") and hasattr(value, "z"):
        keys = ("x", "y", "z", "w") if hasattr(value, "w") else ("x", "y", "z")
        return [float(getattr(value, k)) for k in keys], tuple(f"_{k}" for k in keys)
    if hasattr(value, "data") and not isinstance(value, (np.ndarray, list, tuple)):
        return _components(value.data, topic, field)
    if isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool):
        return [float(value)], ("",)
    if isinstance(value, (np.ndarray, list, tuple)):
        arr = np.asarray(value, dtype=np.float64).reshape(-1)
        return arr.tolist(), tuple(f"_{i + 1}" for i in range(arr.size))
    raise ValueError(f"The field {field or '(message)'!r} of topic {topic!r} holds a "
                     f"{type(value).__name__}, not numbers (a Vector3, a quaternion, an "
                     "array or a number); name a numeric field with /topic:field.path.")


def _stamp(msg, t_receive_ns: int) -> float:
    header = getattr(msg, "header", None)
    stamp = getattr(header, "stamp", None)
    if stamp is not None:
        s = float(stamp.sec) + 1e-9 * float(stamp.nanosec)
        if s > 0:
            return s
    return 1e-9 * t_receive_ns


def read_bag(path, topics: Mapping[str, tuple[str, str]], *, time_column: str = "time_s",
             where: str = "read_bag") -> Table:
    """Read a ROS 1 (``.bag``) or ROS 2 (folder, ``.db3``/``.mcap``) bag into a Table.

    Parameters
    ----------
    path : str or path-like
        The bag (a ROS 2 bag is its folder).
    topics : mapping of str to (topic, field_path)
        Output column -> message field (see :func:`parse_topic_map`). A field with x, y, z
        (and w) components gives the columns ``column_x``, ``column_y``, ``column_z``; an array
        of m numbers ``column_1`` ... ``column_m``; a number the column itself.
    time_column : str
        Name of the time column (s): the header stamps of the first topic (its receive times
        where a message has no header).
    where : str
        The caller, for messages.

    Returns
    -------
    Table
        One row per message of the first topic inside the time span of every other topic;
        the other topics are interpolated linearly to its times.

    Raises
    ------
    ImportError
        When ``rosbags`` is not installed (with the command that installs it).
    ValueError
        Naming the bag and the topic: a missing topic, a field that is not numeric, a topic
        without messages.
    """
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError as exc:
        raise ImportError("Reading ROS bags needs the optional package 'rosbags': "
                          "pip install rosbags (or pip install 'windnav[rosbag]')",
                          name=exc.name) from exc
    path = Path(path)
    source = str(path)
    if not path.exists():
        raise ValueError(f"The bag {source!r} given to {where} does not exist.")
    if not topics:
        raise ValueError(f"The '--topic' parameter of {where} must map at least one column "
                         "to a topic to read a bag.")
    series: dict[str, tuple[np.ndarray, np.ndarray, tuple[str, ...]]] = {}
    try:
        reader = AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        reader.open()
    except Exception as exc:  # rosbags raises its own reader errors for a corrupt bag
        raise ValueError(f"The bag {source!r} given to {where} cannot be read: "
                         f"{type(exc).__name__}: {exc}") from None
    try:
        by_topic = {c.topic: c for c in reader.connections}
        for name, (topic, field) in topics.items():
            if topic not in by_topic:
                raise ValueError(f"The bag {source!r} given to {where} has no topic {topic!r} "
                                 f"(for column {name!r}); it has {sorted(by_topic)}.")
            conns = [c for c in reader.connections if c.topic == topic]
            times, rows, suffixes = [], [], None
            for conn, t_ns, raw in reader.messages(connections=conns):
                msg = reader.deserialize(raw, conn.msgtype)
                value = msg
                for part in filter(None, field.split(".")):
                    if not hasattr(value, part):
                        raise ValueError(f"The topic {topic!r} of bag {source!r} ("
                                         f"{conn.msgtype}) has no field {field!r} (for column "
                                         f"{name!r}).")
                    value = getattr(value, part)
                nums, sfx = _components(value, topic, field)
                if suffixes is None:
                    suffixes = sfx
                elif len(sfx) != len(suffixes):
                    raise ValueError(f"The field {field!r} of topic {topic!r} in bag "
                                     f"{source!r} changes length between messages.")
                times.append(_stamp(msg, t_ns))
                rows.append(nums)
            if not rows:
                raise ValueError(f"The topic {topic!r} of bag {source!r} (for column "
                                 f"{name!r}) holds no messages.")
            order = np.argsort(times, kind="stable")
            series[name] = (np.asarray(times)[order], np.asarray(rows)[order], suffixes)
    finally:
        reader.close()
    return _align(series, source, time_column)


def _align(series, source: str, time_column: str) -> Table:
    """Interpolate every series onto the times of the first, inside their common span."""
    names = list(series)
    t0 = series[names[0]][0]
    lo = max(s[0][0] for s in series.values())
    hi = min(s[0][-1] for s in series.values())
    keep = (t0 >= lo) & (t0 <= hi)
    t = t0[keep]
    columns = {time_column: t}
    for name in names:
        ts, vals, suffixes = series[name]
        for j, sfx in enumerate(suffixes):
            col = vals[:, j]
            columns[name + sfx] = col[keep] if name == names[0] else np.interp(t, ts, col)
    return Table(source, columns)
