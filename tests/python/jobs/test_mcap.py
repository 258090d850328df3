"""MCAP logs with ROS 2 messages (rrr_robot.core.mcap_log, ``rrr writing --mcap``), read back by
readers we do not write with:

- rosbags (its own MCAP reader and CDR decoder, the types built from the file's own schemas):
  every message of every topic equals the run's CSV bit for bit (float64), the stamps are the
  table's t; the TF chain base_link -> link1 -> link2 -> link3 -> tool equals Model.fk to 1e-12
  m and every dh_frame equals Model.fk_frames; our CDR bytes are what rosbags serializes for the
  same messages; the schemas are rosbags' ROS 2 Humble definitions of the standard types;
- mcap's own readers (the stream reader with every CRC checked, the indexed reader) and
  mcap-ros2-support's decoder: the same messages;
- any table (a few columns, extra column groups, NaN rows of a diverged run), several chunks,
  bad tables refused, a failed write leaving no file, no mcap package refused before a run.

``rrr hil bench --mcap`` (the bench's nodes): can/test_hil_results.py.
"""

from __future__ import annotations

import subprocess
import sys
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rrr_robot as rr
from mcap.reader import make_reader
from mcap.stream_reader import StreamReader
from mcap_ros2.decoder import DecoderFactory
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rrr_robot.core import mcap_bulk, mcap_log
from rrr_robot.core.mcap_log import SCHEMAS, write_mcap
from rrr_robot.core.robot import read_robot_file
from rrr_robot.core.tables import read_csv_table
from rrr_robot.core.urdf import robot_urdf
from support.mcap_support import rosbags_messages, same

ROBOT = read_robot_file()


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, np.ndarray]]:
    """``rrr writing --mcap`` on the ctc scenario (FMUs through FMPy), as a user runs it."""
    out = tmp_path_factory.mktemp("mcap") / "results"
    subprocess.run([sys.executable, "-m", "rrr_robot", "writing", "--scenario", "ctc",
                    "--no-figures", "--mcap", "--out", str(out), "-q"], check=True)
    return out / "ctc.mcap", read_csv_table(out / "ctc.csv")


@pytest.fixture(scope="module")
def messages(run) -> tuple[dict[str, list[tuple[int, Any, bytes]]], Any]:
    """Every message of the run's file as rosbags reads it: topic -> (log time, message, raw)."""
    return rosbags_messages(run[0])


def col3(table: dict[str, np.ndarray], name: str) -> np.ndarray:
    return np.stack([table[f"{name}[{i}]"] for i in (1, 2, 3)], axis=1)


def test_rosbags_reads_every_message_equal_to_the_csv(run, messages) -> None:
    _, table = run
    got, _ = messages
    ns = np.rint(table["t"] * 1e9).astype(np.int64)
    n = ns.size
    assert {k: len(v) for k, v in got.items()} == {
        "/robot_description": 1, "/tf_static": 1, "/tf": n, "/joint_states": n,
        "/joint_accelerations": n, "/reference/joint_states": n, "/reference/tip": n,
        "/tip": n, "/control/u": n, "/control/u_n": n, "/control/u_c": n}
    assert got["/robot_description"][0][1].data == robot_urdf(ROBOT)
    for topic, msgs in got.items():
        stamps = np.array([m[0] for m in msgs])
        assert same(stamps, ns[:1] if len(msgs) == 1 else ns), topic
    def field(topic: str, get) -> np.ndarray:
        return np.array([get(m[1]) for m in got[topic]])
    for topic in ("/joint_states", "/reference/joint_states", "/tip", "/reference/tip"):
        sec = field(topic, lambda m: m.header.stamp.sec)
        nsec = field(topic, lambda m: m.header.stamp.nanosec)
        assert same(sec * 1_000_000_000 + nsec, ns), topic
    assert same(field("/joint_states", lambda m: m.position), col3(table, "q"))
    assert same(field("/joint_states", lambda m: m.velocity), col3(table, "qd"))
    effort = ROBOT.model.torque_from_voltage(col3(table, "qd"), col3(table, "u"))
    assert same(field("/joint_states", lambda m: m.effort), effort)
    assert field("/joint_states", lambda m: tuple(m.name))[0].tolist() == \
        ["joint1", "joint2", "joint3"]
    assert same(field("/reference/joint_states", lambda m: m.position), col3(table, "q_ref"))
    assert same(field("/reference/joint_states", lambda m: m.velocity), col3(table, "qd_ref"))
    for topic, name in (("/tip", "tip"), ("/reference/tip", "x_ref")):
        xyz = field(topic, lambda m: (m.point.x, m.point.y, m.point.z))
        assert same(xyz, np.stack([table[f"{name}.{a}"] for a in "xyz"], axis=1)), topic
        assert {m[1].header.frame_id for m in got[topic]} == {"base_link"}
    for topic, name in (("/joint_accelerations", "qdd"), ("/control/u", "u"),
                        ("/control/u_n", "u_n"), ("/control/u_c", "u_c")):
        assert same(field(topic, lambda m: m.data), col3(table, name)), topic


def quat_matrix(q: np.ndarray) -> np.ndarray:
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1)], -2)


def homogeneous(transforms: list) -> np.ndarray:
    """(n, 4, 4) of geometry_msgs/Transform."""
    t = np.array([(tf.translation.x, tf.translation.y, tf.translation.z) for tf in transforms])
    r = np.array([(tf.rotation.x, tf.rotation.y, tf.rotation.z, tf.rotation.w)
                  for tf in transforms])
    out = np.zeros((len(transforms), 4, 4))
    out[:, :3, :3], out[:, :3, 3], out[:, 3, 3] = quat_matrix(r), t, 1.0
    return out


def test_tf_chain_equals_fk(run, messages) -> None:
    _, table = run
    got, _ = messages
    static = {tf.child_frame_id: (tf.header.frame_id, homogeneous([tf.transform])[0])
              for tf in got["/tf_static"][0][1].transforms}
    assert set(static) == {"dh_frame1", "dh_frame2", "tool"}
    tfs = [m[1].transforms for m in got["/tf"]]
    edges = {(tf.header.frame_id, tf.child_frame_id) for row in tfs for tf in row}
    assert edges == {("base_link", "link1"), ("link1", "link2"), ("link2", "link3")}
    assert all([tf.child_frame_id for tf in row] == ["link1", "link2", "link3"] for row in tfs)
    pose = {"base_link": np.broadcast_to(np.eye(4), (len(tfs), 4, 4))}
    for k, child in enumerate(("link1", "link2", "link3")):
        parent = tfs[0][k].header.frame_id
        pose[child] = pose[parent] @ homogeneous([row[k].transform for row in tfs])
    for child, (parent, rel) in static.items():
        pose[child] = pose[parent] @ rel
    q = col3(table, "q")
    frames = ROBOT.model.fk_frames(q)
    x, rot = ROBOT.model.fk(q)
    for k, name in ((1, "dh_frame1"), (2, "dh_frame2"), (3, "tool")):
        np.testing.assert_allclose(pose[name], frames[:, k], rtol=0, atol=1e-12)
    assert float(np.max(np.abs(pose["tool"][:, :3, 3] - x))) < 1e-12
    np.testing.assert_allclose(pose["tool"][:, :3, :3], rot, rtol=0, atol=1e-12)
    # the plant's own tip output (the table's tip column) is where the TF chain puts the tool
    tip = np.stack([table[f"tip.{a}"] for a in "xyz"], axis=1)
    np.testing.assert_allclose(tip, x, rtol=0, atol=1e-12)


def test_cdr_bytes_are_rosbags_serialization(messages) -> None:
    got, typestore = messages
    for topic, msgs in got.items():
        for k in (0, len(msgs) // 2, len(msgs) - 1):
            _, msg, raw = msgs[k]
            assert typestore.serialize_cdr(msg, msg.__msgtype__) == raw, topic


def test_schemas_are_the_standard_ros2_types() -> None:
    humble = get_typestore(Stores.ROS2_HUMBLE)
    for name, text in SCHEMAS.items():
        main, *deps = text.split("=" * 80 + "\n")
        types = get_types_from_msg(main, name)
        for dep in deps:
            head, body = dep.split("\n", 1)
            assert head.startswith("MSG: ")
            pkg, kind = head[5:].split("/")
            types.update(get_types_from_msg(body, f"{pkg}/msg/{kind}"))
        for kind, definition in types.items():
            assert definition == humble.fielddefs[kind], kind


def test_mcap_readers_check_crcs_indexes_and_latched_topics(run) -> None:
    path, table = run
    with path.open("rb") as fh:
        kinds = defaultdict(int)
        for record in StreamReader(fh, validate_crcs=True).records:
            kinds[type(record).__name__] += 1
    assert kinds["Header"] == kinds["Footer"] == kinds["Statistics"] == 1
    assert kinds["Message"] == 9 * table["t"].size + 2
    with path.open("rb") as fh:
        reader = make_reader(fh)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        assert summary.statistics.message_count == 9 * table["t"].size + 2
        channels = {c.topic: c for c in summary.channels.values()}
        for topic in ("/robot_description", "/tf_static"):
            assert "durability: 1" in channels[topic].metadata["offered_qos_profiles"]
        assert reader.get_header().profile == "ros2"
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
        assert metadata["rrr_robot"]["scenario"] == "ctc"
        # the indexed reader: log times in order, the q of /joint_states in time order
        times = [m.log_time for _, _, m in reader.iter_messages(topics=["/joint_states"])]
        assert times == np.rint(table["t"] * 1e9).astype(np.int64).tolist()
    # mcap-ros2-support's decoder (its own ros2msg parser and CDR reader)
    with path.open("rb") as fh:
        decoded = defaultdict(list)
        for _, channel, _, msg in make_reader(
                fh, decoder_factories=[DecoderFactory()]).iter_decoded_messages(
                    topics=["/joint_states", "/robot_description", "/control/u"]):
            decoded[channel.topic].append(msg)
    assert same(np.array([m.position for m in decoded["/joint_states"]]), col3(table, "q"))
    assert same(np.array([m.data for m in decoded["/control/u"]]), col3(table, "u"))
    assert [m.data for m in decoded["/robot_description"]] == [robot_urdf(ROBOT)]


def small_table(n: int = 50, **extra: np.ndarray) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(4)
    cols = {"t": np.arange(n) * 0.01}
    for i in (1, 2, 3):
        cols[f"q[{i}]"] = rng.uniform(-3, 3, n)
    return cols | extra


def test_any_table_and_several_chunks(tmp_path, monkeypatch) -> None:
    cols = small_table(400, **{f"foo[{i}]": np.full(400, float(i)) for i in (1, 2, 3)})
    monkeypatch.setattr(mcap_bulk, "CHUNK_BYTES", 2000)     # many chunks
    path = write_mcap(tmp_path / "a.mcap", cols)
    got, _ = rosbags_messages(path)
    assert set(got) == {"/robot_description", "/tf_static", "/tf", "/joint_states",
                        "/signals/foo"}
    js = [m[1] for m in got["/joint_states"]]
    assert same(np.array([m.position for m in js]), col3(cols, "q"))
    assert all(m.velocity.tolist() == [0.0, 0.0, 0.0] and m.effort.size == 0 for m in js)
    assert same(np.array([m[1].data for m in got["/signals/foo"]]), col3(cols, "foo"))
    with path.open("rb") as fh:
        summary = make_reader(fh).get_summary()
        assert summary is not None and len(summary.chunk_indexes) > 10


def test_nan_rows_are_written_as_they_are(tmp_path) -> None:
    cols = small_table(20, **{f"qd[{i}]": np.zeros(20) for i in (1, 2, 3)},
                       **{f"u[{i}]": np.ones(20) for i in (1, 2, 3)})
    cols["q[2]"][5:] = np.nan           # a run that diverged at row 5
    cols["qd[1]"][7] = np.inf
    got, _ = rosbags_messages(write_mcap(tmp_path / "nan.mcap", cols))
    js = [m[1] for m in got["/joint_states"]]
    assert same(np.array([m.position for m in js]), col3(cols, "q"))
    effort = np.array([m.effort for m in js])
    assert np.all(np.isnan(effort[7])) and np.all(np.isfinite(np.delete(effort, 7, axis=0)))


@pytest.mark.parametrize(("change", "message"), [
    (lambda c: c.pop("t"), "no column 't'"),
    (lambda c: c.pop("q[2]"), r"q\[1\], q\[2\], q\[3\]"),
    (lambda c: c.__setitem__("t", c["t"] - 1.0), "finite times"),
    (lambda c: c["t"].__setitem__(3, np.nan), "finite times"),
    (lambda c: c.__setitem__("q[1]", c["q[1]"][:-1]), "shape"),
    (lambda c: [c.__setitem__(k, v[:0]) for k, v in list(c.items())], "no rows"),
])
def test_bad_tables_are_refused(tmp_path, change, message) -> None:
    cols = small_table()
    change(cols)
    with pytest.raises(rr.BadInputError, match=message):
        write_mcap(tmp_path / "bad.mcap", cols)
    assert list(tmp_path.iterdir()) == []


def test_a_failed_write_leaves_no_file(tmp_path, monkeypatch) -> None:
    def broken(out, **kwargs) -> None:
        out.write(b"\x89MCAP0\r\n half a file")
        raise OSError("disk full")
    monkeypatch.setattr(mcap_log, "write_container", broken)
    with pytest.raises(OSError, match="disk full"):
        write_mcap(tmp_path / "x.mcap", small_table())
    assert list(tmp_path.iterdir()) == []


def test_without_mcap_the_run_is_refused_before_it_starts(tmp_path, monkeypatch) -> None:
    monkeypatch.setitem(sys.modules, "mcap.records", None)
    with pytest.raises(rr.BadInputError, match=r"rrr_robot\[mcap\]"):
        write_mcap(tmp_path / "x.mcap", small_table())
    from rrr_robot.writing.job import WritingJob, run_writing

    with pytest.raises(rr.BadInputError, match=r"rrr_robot\[mcap\]"):
        run_writing(WritingJob(out=tmp_path / "out", scenarios=["ctc"], figures=False,
                               engine="native", mcap=True))
    assert not (tmp_path / "out" / "ctc.csv").exists()


def test_run_ssp_writes_the_mcap_of_its_table(tmp_path) -> None:
    """``rrr run-ssp --mcap`` (FMPy's SSP support): the file reads back equal to its CSV."""
    ssp = tmp_path / "ctc.ssp"
    for args in (["ssp", "--out", str(ssp)],
                 ["run-ssp", str(ssp), "--tool", "fmpy", "--no-figures", "--mcap", "--out",
                  str(tmp_path / "run")]):
        subprocess.run([sys.executable, "-m", "rrr_robot", *args, "-q"], check=True,
                       capture_output=True)
    table = read_csv_table(tmp_path / "run" / "ctc.csv")
    got, _ = rosbags_messages(tmp_path / "run" / "ctc.mcap")
    assert same(np.array([m[1].position for m in got["/joint_states"]]), col3(table, "q"))
    assert same(np.array([m[1].data for m in got["/control/u"]]), col3(table, "u"))
    assert same(np.array([m[0] for m in got["/tip"]]), np.rint(table["t"] * 1e9))
