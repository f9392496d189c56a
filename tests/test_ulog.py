"""The ULog power-log reader: a minimal ULog written here byte by byte (ULog spec: header,
flag bits, formats, subscriptions, data), read into time and power; the reader registry and
the fit command on a .ulg."""

import struct

import numpy as np
import pytest

pytest.importorskip("pyulog")

from eaplan_drake.logfit.powerlog import PowerLogError  # noqa: E402
from eaplan_drake.logfit.readers import PowerLogReaderName, ReadAnyPowerLog  # noqa: E402
from eaplan_drake.logfit.ulog import ReadULog  # noqa: E402
from eaplan_drake.registry import POWER_LOG_READERS  # noqa: E402


def Message(kind: str, payload: bytes) -> bytes:
    """One ULog message: uint16 size, uint8 type, payload."""
    return struct.pack("<HB", len(payload), ord(kind)) + payload


def WriteULog(path, topics):
    """A ULog (version 1) with ``topics``: {name: (fields, rows)}, fields [(type, name)] after
    ``uint64_t timestamp``, rows [(timestamp [µs], *values)]; one instance each."""
    out = bytearray(b"ULog\x01\x12\x35" + bytes([1]) + struct.pack("<Q", 0))
    out += Message("B", bytes(16) + struct.pack("<3Q", 0, 0, 0))
    codes = {"float": "f", "uint8_t": "B", "int32_t": "i"}
    for name, (fields, _) in topics.items():
        text = f"{name}:uint64_t timestamp;" + "".join(f"{t} {n};" for t, n in fields)
        out += Message("F", text.encode())
    for msg_id, name in enumerate(topics):
        out += Message("A", struct.pack("<BH", 0, msg_id) + name.encode())
    for msg_id, (fields, rows) in enumerate(topics.values()):
        fmt = "<Q" + "".join(codes[t] for t, _ in fields)
        for row in rows:
            out += Message("D", struct.pack("<H", msg_id) + struct.pack(fmt, *row))
    path.write_bytes(bytes(out))
    return path


def BatteryRows(n=200, step_us=100_000):
    t = np.arange(n) * step_us + 5_000_000
    voltage = 16.0 - 0.002 * np.arange(n)
    current = 2.0 + np.sin(np.arange(n) / 7.0)
    return (
        t,
        voltage,
        current,
        [(int(a), float(b), float(c)) for a, b, c in zip(t, voltage, current, strict=True)],
    )


BATTERY_FIELDS = [("float", "voltage_v"), ("float", "current_a")]


def test_a_ulog_battery_status_gives_voltage_times_current(tmp_path):
    t, v, i, rows = BatteryRows()
    rows[10] = (rows[10][0], rows[10][1], -1.0)  # PX4: current not measured
    gps = ([("float", "lat")], [(1_000_000, 55.0)])
    path = WriteULog(
        tmp_path / "flight.ulg",
        {"vehicle_gps_position": gps, "battery_status": (BATTERY_FIELDS, rows)},
    )
    log = ReadULog(path)
    keep = np.arange(len(rows)) != 10
    np.testing.assert_allclose(log.times, (t[keep] - t[0]) * 1e-6, atol=1e-9)
    # float32 in the file: relative 1e-6
    np.testing.assert_allclose(log.power, (v * i)[keep], rtol=2e-6)
    assert "battery_status[0]" in log.source and "voltage_v × current_a" in log.source


def test_a_ulog_without_battery_status_lists_its_topics(tmp_path):
    topics = {
        "sensor_gyro": ([("float", "x")], [(1, 0.0), (2, 1.0)]),
        "actuator_outputs": ([("float", "o")], [(1, 0.0)]),
    }
    path = WriteULog(tmp_path / "nobat.ulg", topics)
    with pytest.raises(
        PowerLogError,
        match=r"no 'battery_status' topic; the log has 2: actuator_outputs, sensor_gyro",
    ) as e:
        ReadULog(path)
    assert str(e.value).startswith(str(path)) and "\n" not in str(e.value)


def test_a_file_that_is_not_a_ulog_is_one_line(tmp_path):
    path = tmp_path / "junk.ulg"
    path.write_bytes(b"not a ulog at all, just text\n" * 3)
    with pytest.raises(PowerLogError, match=r"junk\.ulg: not a readable ULog file") as e:
        ReadULog(path)
    assert "\n" not in str(e.value)


def test_csv_options_are_refused_for_a_ulog(tmp_path):
    _, _, _, rows = BatteryRows()
    path = WriteULog(tmp_path / "f.ulg", {"battery_status": (BATTERY_FIELDS, rows)})
    with pytest.raises(PowerLogError, match=r"--power-column: for CSV logs only"):
        ReadAnyPowerLog(path, power_column="3", time_column=None)


def test_the_reader_is_chosen_by_suffix_or_name(tmp_path):
    assert POWER_LOG_READERS.Names() == ("csv", "ulog")
    for name in POWER_LOG_READERS:
        assert callable(POWER_LOG_READERS.Factory(name))
    assert PowerLogReaderName("a/flight.ULG") == "ulog"
    assert PowerLogReaderName("a/flight.csv") == "csv"
    assert PowerLogReaderName("a/pprz_energy.txt") == "csv"
    assert PowerLogReaderName("a/flight.bin", "ulog") == "ulog"
    with pytest.raises(ValueError, match=r"fit --reader: must be one of csv, ulog, got 'bin'"):
        PowerLogReaderName("a/flight.bin", "bin")


def test_fit_reads_a_ulog_like_the_csv(tmp_path, capsys):
    from eaplan_drake.cli import main

    n = 2400  # 240 s at 10 Hz: a periodic load of period 30 s
    t = np.arange(n) * 100_000
    current = (
        2.0
        + 0.5 * np.sin(2 * np.pi * t * 1e-6 / 30.0)
        + 0.05 * np.random.default_rng(0).standard_normal(n)
    )
    rows = [(int(a), 15.0, float(c)) for a, c in zip(t, current, strict=True)]
    path = WriteULog(tmp_path / "flight.ulg", {"battery_status": (BATTERY_FIELDS, rows)})
    code = main(
        ["fit", str(path), "--out", str(tmp_path / "fit"), "--orders", "0,1", "--period", "30"]
    )
    out = capsys.readouterr()
    assert code == 0, out.err
    assert "flight.ulg (ULog battery_status[0])" in out.out
    assert (tmp_path / "fit" / "fit.yaml").is_file()


def test_without_pyulog_a_ulog_is_one_line_naming_the_extra(tmp_path, monkeypatch):
    import sys

    from eaplan_drake.errors import MissingExtraError

    _, _, _, rows = BatteryRows()
    path = WriteULog(tmp_path / "f.ulg", {"battery_status": (BATTERY_FIELDS, rows)})
    monkeypatch.setitem(sys.modules, "pyulog", None)
    with pytest.raises(
        MissingExtraError, match=r"needs pyulog: pip install 'eaplan-drake\[ulog\]'"
    ):
        ReadULog(path)


def test_a_ulog_cut_inside_a_message_is_read_up_to_the_cut_and_says_so(tmp_path):
    from eaplan_drake.logfit.ulog import ULogCut

    rows = BatteryRows()[3]
    whole = WriteULog(tmp_path / "whole.ulg", {"battery_status": (BATTERY_FIELDS, rows)})
    data = whole.read_bytes()
    assert ULogCut(whole) is None
    assert "truncated" not in ReadULog(whole).source
    cut = tmp_path / "cut.ulg"
    cut.write_bytes(data[: len(data) // 2 + 3])
    at = ULogCut(cut)
    assert at is not None and at < len(data) // 2 + 3
    log = ReadULog(cut)
    assert f"truncated (it ends inside the message at byte {at})" in log.source
    assert 16 <= log.times.size < len(rows)
