"""Reading a log: the valid one as frames, and every malformed one refused with its own message."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest
from logs.mini_log import mini_files, write_log

from azgym.bench.suites.data import UNLABELLED, log_cases
from azgym.errors import DependencyNotInstalled
from azgym.logs import LogError, frame_measurements, read_log
from azgym.logs.files import MAX_TABLE_BYTES
from azgym.logs.problems import MAX_PROBLEMS


def test_a_valid_log_reads_as_frames_with_truth_and_motion(mini_log):
    log = read_log(mini_log)
    cases = log_cases(log)
    assert [len(c.measurements) for c in cases] == [4, 6, 0]  # frame 2: no detection
    assert cases[1].measurements.ids.tolist() == [1, 2, 3, 4, 99, -1]  # unknown ids are kept
    assert cases[0].measurements.quality.shape == (4,)  # one quality column: 1-D
    assert cases[1].pose == (5.1, 5.0, 0.1)
    assert cases[0].initial == cases[0].pose and cases[1].initial is None
    assert {c.sequence for c in cases} == {"mini"} and {c.cause for c in cases} == {UNLABELLED}
    # Motion: the samples after the previous frame, up to the frame's time; 0.25 s is unused.
    assert [c.motion.odometry.time.tolist() for c in cases] == [[], [0.05], [0.15]]
    assert np.isnan(cases[1].motion.imu.heading[0]) and cases[2].motion.imu.heading[0] == 0.1
    assert cases[2].motion.imu.accel.shape == (1, 2)
    assert len(log.sha256) == 64


def test_a_log_without_truth_is_read_but_not_scored(tmp_path):
    files = mini_files()
    files["frames.csv"] = "frame,time\n0,0.0\n1,0.1\n2,0.2\n"
    log = read_log(write_log(tmp_path / "log", files))
    assert [len(m) for m in frame_measurements(log)] == [4, 6, 0]
    with pytest.raises(LogError, match="no truth .* not scored"):
        log_cases(log)


def _replace(name, old, new):
    def change(files):
        assert old in files[name], (name, old)
        files[name] = files[name].replace(old, new, 1)
    return change


def _set(name, content):
    def change(files):
        files[name] = content
    return change


def _delete(name):
    def change(files):
        del files[name]
    return change


def _azimuths(files, change):
    """Change every azimuth of detections.csv."""
    lines = files["detections.csv"].splitlines()
    rows = [line.split(",") for line in lines[1:]]
    files["detections.csv"] = "\n".join([lines[0], *(",".join(
        [*row[:2], repr(change(float(row[2]))), *row[3:]]) for row in rows)]) + "\n"


MALFORMED = {
    "no manifest": (_delete("log.toml"), r"log.toml: missing"),
    "unknown format": (_replace("log.toml", "format = 1", "format = 3"),
                       r"log.toml: format: this azgym reads log formats 1 and 2, the log says 3"),
    "profile in format 1": (_replace("log.toml", "[map]",
                                     "[sensor]\ndelta_alpha_d = 0.01\n\n[map]"),
                            r"log.toml: unknown key 'sensor'"),
    "manifest typo": (_replace("log.toml", "simulated =", "simulatd = true\nsimulated ="),
                      r"log.toml: unknown key 'simulatd'"),
    "manifest not TOML": (_replace("log.toml", "name = ", "name = = "), r"not valid TOML"),
    "name not plain": (_replace("log.toml", 'name = "mini"', 'name = "../mini"'),
                       r"log.toml: name: must be a plain file name \(.*at most 64 characters\), "
                       r"got '../mini'"),
    "name too long": (_replace("log.toml", 'name = "mini"', f'name = "{"m" * 65}"'),
                      r"log.toml: name: must be a plain file name"),
    "no map": (_replace("log.toml", 'beacons = "beacons.csv"', ""), r"map: give exactly one"),
    "no frames": (_delete("frames.csv"), r"frames.csv: missing"),
    "bad number": (_replace("frames.csv", "1,0.1,", "1,abc,"),
                   r"frames.csv, line 3, column time: 'abc' is not a number"),
    "nan": (_replace("detections.csv", ",1.5\n", ",nan\n"),
            r"detections.csv, line 2, column quality_size: 'nan' is not finite"),
    "inf azimuth": (_replace("detections.csv", "1,99,0.5", "1,99,inf"),
                    r"line 10, column azimuth: 'inf' is not finite"),
    "azimuth in degrees": (_replace("detections.csv", "1,99,0.5", "1,99,45.0"),
                           r"line 10, column azimuth: 45.0 is outside \[-π, π\]"),
    "time running back": (_replace("frames.csv", "2,0.2", "2,0.05"),
                          r"frames.csv, line 4, column time: 0.05 is less than the row before's "
                          r"0.1 \(a clock never runs back\)"),
    "frame numbers repeat": (_replace("frames.csv", "2,0.2", "1,0.2"),
                             r"frames.csv, line 4, column frame: 1 is not greater"),
    "unknown frame": (_replace("detections.csv", "1,99,", "7,99,"),
                      r"line 10, column frame: frame 7 is not in frames.csv"),
    "out of frame order": (_replace("detections.csv", "1,-1,", "0,-1,"),
                           r"line 11, column frame: frame 0 after frame 1"),
    "duplicate detection": (_replace("detections.csv", "1,-1,-0.5", "1,99,0.5"),
                            r"line 11, column id: the same detection \(id 99, azimuth 0.5\) "
                            r"as line 10"),
    "id not whole": (_replace("detections.csv", "1,99,", "1,9.5,"),
                     r"line 10, column id: '9.5' is not a whole number"),
    "truth partly present": (_set("frames.csv", "frame,time,x,y\n0,0.0,5,5\n"),
                             r"truth partly present: columns x, y without heading"),
    "truth cell empty": (_replace("frames.csv", "1,0.1,5.1,5.0,0.1", "1,0.1,5.1,5.0,"),
                         r"frames.csv, line 3, column heading: empty \(a number is required\)"),
    "odometry out of order": (_replace("odometry.csv", "0.15,", "0.01,"),
                              r"odometry.csv, line 3, column time: 0.01 is less than"),
    "imu column missing": (_replace("imu.csv", "time,yaw_rate,ax,ay", "time,yaw_rate,ax,ayy"),
                           r"imu.csv: no column 'ay'"),
    "unknown column": (_replace("detections.csv", "quality_size", "size"),
                       r"detections.csv: unknown column 'size'"),
    "short row": (_replace("frames.csv", "1,0.1,5.1,5.0,0.1", "1,0.1,5.1"),
                  r"frames.csv, line 3: 3 cells, the header names 5 columns"),
    "unknown label": (lambda f: f.update({"detections.csv": f["detections.csv"].replace(
        "quality_size", "quality_size,label").replace("\n", ",direct\n").replace(
        "label,direct", "label").replace("1,-1,-0.5,1.0,direct", "1,-1,-0.5,1.0,lamp")}),
                      r"column label: 'lamp' is no label"),
    "sequence resumes": (_set("frames.csv", "frame,time,x,y,heading,sequence\n0,0.0,5,5,0,a\n"
                              "1,0.1,5,5,0,b\n2,0.2,5,5,0,a\n"),
                         r"line 4, column sequence: sequence 'a' resumes after another"),
    "duplicate beacon id": (_replace("beacons.csv", "2,10.0", "1,10.0"),
                            r"beacons.csv: BeaconMap.ids must be unique; duplicated: \[1\]"),
    "not UTF-8": (lambda f: f.update({"frames.csv": f["frames.csv"].encode() + b"3,0.3,\xe9\n"}),
                  r"frames.csv: not UTF-8 text: byte 0xe9"),
    "NUL byte": (lambda f: f.update({"odometry.csv": "time,speed,steer\n0.05,1\x00,0\n"}),
                 r"odometry.csv, line 2, column speed: '1\\x00' is not a number"),
    "both CSV and Parquet": (lambda f: f.update({"imu.parquet": b"PAR1"}),
                             r"imu.parquet: both imu.csv and imu.parquet exist"),
    "format not whole": (_replace("log.toml", "format = 1", "format = 1.0"),
                         r"format: this azgym reads log formats 1 and 2, the log says 1.0 \(the "
                         r"format is a whole number\)"),
    "scenario typo": (_replace("log.toml", 'beacons = "beacons.csv"',
                               'scenario = "warehouse-smal"'),
                      r"map.scenario: unknown scenario 'warehouse-smal'. Did you mean "
                      r"'warehouse-small'\?"),
    "non-ASCII digits": (_replace("detections.csv", "1,99,", "1,\u0669\u0669,"),
                         r"line 10, column id: '\u0669\u0669' is not a whole number"),
    "fullwidth digits": (_replace("frames.csv", "1,0.1,", "1,\uff10.1,"),
                         r"line 3, column time: '\uff10.1' is not a number"),
    "long cell cut": (_replace("frames.csv", "1,0.1,", "1," + "x" * 5000 + ","),
                      r"line 3, column time: 'x{39}… is not a number$"),
    # Unit mistakes: valid numbers, wrong figures.
    "heading in degrees": (_replace("frames.csv", "1,0.1,5.1,5.0,0.1", "1,0.1,5.1,5.0,5.7"),
                           r"frames.csv, line 3, column heading: 5.7 is outside \[-3.142, "
                           r"3.142\] \(radians, counter-clockwise from the x-axis; degrees\?\)"),
    "truth in millimetres": (_replace("frames.csv", "1,0.1,5.1,", "1,0.1,5100.0,"),
                             r"line 3, column x: 5100.0 is outside the map's extent \[-50, 60\] "
                             r"m \(the beacons' extent and 50 m; millimetres\?\)"),
    "truth huge": (_replace("frames.csv", "1,0.1,5.1,5.0", "1,0.1,5.1,1e300"),
                   r"line 3, column y: 1e\+300 is outside the map's extent"),
    "speed huge": (_replace("odometry.csv", "0.05,1.0,", "0.05,1e300,"),
                   r"odometry.csv, line 2, column speed: 1e\+300 is outside \[-20, 20\] "
                   r"\(m/s; km/h or mm/s\?\)"),
    "steer in degrees": (_replace("odometry.csv", "0.15,1.0,0.01", "0.15,1.0,10.0"),
                         r"odometry.csv, line 3, column steer: 10.0 is outside \[-3.142"),
    "yaw rate huge": (_replace("imu.csv", "0.05,0.0,", "0.05,1e300,"),
                      r"imu.csv, line 2, column yaw_rate: 1e\+300 is outside \[-20, 20\]"),
    "accel huge": (_replace("imu.csv", "0.05,0.0,0.1,", "0.05,0.0,981.0,"),
                   r"imu.csv, line 2, column ax: 981.0 is outside \[-100, 100\]"),
    "rate disagrees": (_replace("log.toml", "[map]", "[camera]\nrate_hz = 1000.0\n\n[map]"),
                       r"frames.csv, column time: the median frame interval is 0.1 s, but "
                       r"camera.rate_hz = 1000 says 0.001 s"),
    "times in milliseconds": (lambda f: f.update({
        "log.toml": f["log.toml"].replace("[map]", "[camera]\nrate_hz = 10.0\n\n[map]"),
        "frames.csv": "frame,time,x,y,heading\n0,0.0,5,5,0\n1,100.0,5,5,0\n2,200.0,5,5,0\n",
        "odometry.csv": "time,speed,steer\n", "imu.csv": "time,yaw_rate,ax,ay\n"}),
                              r"frames.csv, column time: the median frame interval is 100 s, "
                              r"but camera.rate_hz = 10 says 0.1 s"),
    "motion on another clock": (
        lambda f: f.update({"odometry.csv": "time,speed,steer\n" + "".join(
            f"{0.05 * k + 1.0!r},1.0,0.0\n" for k in range(5))}),
        r"odometry.csv, column time: none of its samples \(1.0 s to 1.2 s\) lies within the "
        r"frames' time \(0.0 s to 0.2 s, and up to 5 s before a sequence's first frame\): "
        r"another clock"),
    "azimuths clockwise": (lambda f: _azimuths(f, lambda a: -a),
                           r"detections.csv, column azimuth: the azimuths disagree with the truth"
                           r": the median .* over 8 detections of map beacons is 1.57 rad, at "
                           r"most 0.2 is plausible \(they match the predictions negated: "
                           r"measured clockwise\?\)"),
    "azimuths offset": (lambda f: _azimuths(f, lambda a: a + 0.5),
                        r"is 0.5 rad, .* \(they match the predictions turned by 0.5 rad: a "
                        r"heading or camera zero offset\?\)"),
    "azimuths scaled": (lambda f: _azimuths(f, lambda a: a * 0.3),
                        r"over 8 detections .* \(in degrees, or scaled\?\)"),
}


@pytest.mark.parametrize("case", MALFORMED, ids=list(MALFORMED))
def test_each_malformed_log_is_refused_naming_its_problem(tmp_path, case):
    change, message = MALFORMED[case]
    files = mini_files()
    change(files)
    with pytest.raises(LogError, match=message):
        read_log(write_log(tmp_path / "log", files))


def test_every_problem_is_listed_not_only_the_first(tmp_path):
    files = mini_files()
    files["frames.csv"] = files["frames.csv"].replace("1,0.1,", "1,abc,")
    files["odometry.csv"] = files["odometry.csv"].replace("0.15,", "0.01,")
    with pytest.raises(LogError, match=r"2 problems") as caught:
        read_log(write_log(tmp_path / "log", files))
    assert [p.split(",")[0] for p in caught.value.problems] == ["frames.csv", "odometry.csv"]


def test_problems_are_capped(tmp_path):
    files = mini_files()
    files["odometry.csv"] = "time,speed,steer\n" + "x,1,0\n" * (MAX_PROBLEMS + 10)
    with pytest.raises(LogError, match=r"(?s)60 problems.*… and 10 more") as caught:
        read_log(write_log(tmp_path / "log", files))
    assert len(caught.value.problems) == MAX_PROBLEMS


def test_a_huge_table_is_refused_before_it_is_read(tmp_path):
    folder = write_log(tmp_path / "log", mini_files())
    with (folder / "imu.csv").open("r+b") as file:
        file.truncate(MAX_TABLE_BYTES + 1)  # sparse: nothing is written
    with pytest.raises(LogError, match=r"imu.csv: too large: \d+ bytes"):
        read_log(folder)


def test_not_a_folder(tmp_path):
    with pytest.raises(LogError, match="no such folder"):
        read_log(tmp_path / "nowhere")


def test_a_parquet_table_needs_pyarrow(tmp_path):
    if importlib.util.find_spec("pyarrow") is not None:
        pytest.skip("pyarrow is installed")
    files = mini_files()
    del files["imu.csv"]
    files["imu.parquet"] = b"PAR1"
    with pytest.raises(DependencyNotInstalled, match=r'azgym\[parquet\]'):
        read_log(write_log(tmp_path / "log", files))


def test_parquet_tables_read_as_the_csv_ones(tmp_path, mini_log):
    pytest.importorskip("pyarrow")
    import pyarrow as pa
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    files = mini_files()
    for name in ("frames", "detections", "odometry"):
        del files[f"{name}.csv"]
        table = pacsv.read_csv(mini_log / f"{name}.csv")
        if name == "detections":  # ids as integers, azimuths as doubles
            table = table.cast(pa.schema([("frame", pa.int64()), ("id", pa.int64()),
                                          ("azimuth", pa.float64()),
                                          ("quality_size", pa.float64())]))
        pq.write_table(table, tmp_path / f"{name}.parquet")
    folder = write_log(tmp_path / "log", files)
    for name in ("frames", "detections", "odometry"):
        (tmp_path / f"{name}.parquet").rename(folder / f"{name}.parquet")
    from_parquet, from_csv = log_cases(read_log(folder)), log_cases(read_log(mini_log))
    for a, b in zip(from_parquet, from_csv, strict=True):
        assert a.pose == b.pose and a.time == b.time
        assert np.array_equal(a.measurements.azimuth, b.measurements.azimuth)
        assert np.array_equal(a.measurements.ids, b.measurements.ids)
        assert np.array_equal(a.motion.odometry.time, b.motion.odometry.time)


def test_a_bad_parquet_value_is_named_by_row(tmp_path):
    pa = pytest.importorskip("pyarrow")
    import pyarrow.parquet as pq

    files = mini_files()
    del files["odometry.csv"]
    folder = write_log(tmp_path / "log", files)
    pq.write_table(pa.table({"time": [0.05, 0.01], "speed": [1.0, float("nan")],
                             "steer": [0.0, 0.0]}), folder / "odometry.parquet")
    with pytest.raises(LogError, match=r"odometry.parquet, row 2, column time: 0.01 is less "
                                       r"than"):
        read_log(folder)
