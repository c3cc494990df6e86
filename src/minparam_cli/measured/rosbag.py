"""ROS bags (rosbag2 MCAP or SQLite, ROS 1 .bag) of sensor_msgs/JointState, read with the pure-Python
``rosbags`` library (the ``[ros]`` extra; imported only when a bag is read).

A bag becomes the same chunks as a CSV file: a table of t, q, [dq], tau, a row per message, in the
order the messages were recorded.

* t: the header stamp, sec + nanosec, in seconds (ns / 1e9: a stamp of whole milliseconds is the
  same double a CSV holding those seconds gives);
* q, dq, tau: position, velocity and effort, matched by name to the robot's independent
  coordinates (``DataOptions.joint_names``); other joints in the messages are ignored;
* dq is taken when the first message carries velocities, else it is derived like a CSV
  without dq columns; a later message without velocity or effort gives a NaN row (dropped and
  counted by the cleaning).
"""

from __future__ import annotations

import os
import stat
import struct
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from minparam_cli.errors import DataError
from minparam_cli.measured.records import DataOptions

JOINT_STATE = "sensor_msgs/msg/JointState"
BAG_SUFFIXES = (".mcap", ".db3", ".bag")
STORAGE_SUFFIXES = (".mcap", ".db3", ".yaml", ".zstd")  # files of a rosbag2 folder that are read


def coordinate_names(chain) -> tuple[str, ...]:
    """The names a bag's messages must carry: the chain's independent coordinates, in order."""
    return tuple(chain.joint_names[j] for j in chain.coordinates)


def is_bag(path: Path) -> bool:
    """A ROS bag by its name: .mcap, .db3 or .bag, or a folder holding metadata.yaml (rosbag2)."""
    path = Path(path)
    if path.suffix.lower() in BAG_SUFFIXES:
        return True
    return path.is_dir() and (path / "metadata.yaml").exists()


def require_bag(path: Path) -> None:
    """A bag file must be a regular file; a rosbag2 folder must hold regular files only (a FIFO or a
    device among them would hang or never end), refused without opening anything."""
    from minparam_cli.safety import require_regular_file

    if not path.is_dir():
        require_regular_file(path, DataError)
        return
    for entry in sorted(path.iterdir()):
        if entry.suffix.lower() in STORAGE_SUFFIXES or entry.name == "metadata.yaml":
            try:
                mode = os.stat(entry).st_mode
            except OSError as e:
                raise DataError(f"{entry}: cannot read file ({e.strerror})") from None
            if not stat.S_ISREG(mode):
                require_regular_file(entry, DataError)


def short_error(e: BaseException) -> str:
    text = " ".join(str(e).split()) or type(e).__name__
    return text if len(text) <= 160 else text[:157] + "..."


class _Bag:
    """An open bag and the connections of its JointState topic."""

    def __init__(self, path: Path, opts: DataOptions):
        from minparam_cli.optional import import_optional

        import_optional("rosbags", "ros", f"{path}: reading a ROS bag")
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore

        self.src = str(path)
        require_bag(path)
        try:  # a bag without message definitions (older SQLite bags) is read with the Humble types
            self.reader = AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
            self.reader.open()
        except MemoryError:
            raise
        except Exception as e:  # noqa: BLE001 - rosbags, sqlite3, yaml and zstd raise many kinds for a damaged bag
            raise DataError(f"{self.src}: cannot read the bag ({short_error(e)})") from None
        try:
            self.topic, self.connections = self._pick(opts.topic)
        except BaseException:
            self.close()
            raise

    def _pick(self, topic: str | None):
        conns = self.reader.connections
        states = sorted({c.topic for c in conns if c.msgtype == JOINT_STATE})
        if topic is None:
            if not states:
                shown = ", ".join(sorted({f"{c.topic} ({c.msgtype})" for c in conns})[:6]) or "none"
                raise DataError(f"{self.src}: no {JOINT_STATE} topic in the bag (topics: {shown})")
            if len(states) > 1:
                raise DataError(f"{self.src}: {len(states)} {JOINT_STATE} topics ({', '.join(states)}); choose one with --topic")
            topic = states[0]
        chosen = [c for c in conns if c.topic == topic]
        if not chosen:
            raise DataError(f"{self.src}: no topic {topic!r} in the bag ({JOINT_STATE} topics: {', '.join(states) or 'none'})")
        wrong = sorted({c.msgtype for c in chosen if c.msgtype != JOINT_STATE})
        if wrong:
            raise DataError(f"{self.src}: topic {topic} carries {wrong[0]}, expected {JOINT_STATE}")
        return topic, chosen

    def messages(self) -> Iterator[tuple[int, Any]]:
        """(message number from 1, the JointState) in recorded order; a message that cannot be
        decoded is a one-line DataError."""
        k = 0
        try:
            for conn, _, raw in self.reader.messages(connections=self.connections):
                k += 1
                yield k, self.reader.deserialize(raw, conn.msgtype)
        except (MemoryError, DataError, GeneratorExit):
            raise
        except Exception as e:  # noqa: BLE001 - a truncated or damaged record
            raise DataError(f"{self.src}: cannot read message {k + 1} on {self.topic} ({short_error(e)})") from None

    def stamps(self) -> Iterator[int]:
        """The header stamps (ns) of the topic's messages, read from the serialized bytes without
        decoding the rest: a JointState starts with its std_msgs/Header, whose stamp is (CDR, after the
        4-byte encapsulation header) int32 sec, uint32 nanosec, or (ROS 1, after uint32 seq) the same
        two 32-bit words, little-endian."""
        offset = 4
        k = 0
        try:
            for _conn, _, raw in self.reader.messages(connections=self.connections):
                k += 1
                if len(raw) < offset + 8:
                    raise DataError(f"{self.src}: message {k} on {self.topic} is {len(raw)} bytes, too short for a header")
                big = self.reader.is2 and raw[1] == 0  # CDR encapsulation 0x0000: big-endian
                sec, nsec = struct.unpack_from(">iI" if big else "<iI", raw, offset)
                yield sec * 1_000_000_000 + nsec
        except (MemoryError, DataError, GeneratorExit):
            raise
        except Exception as e:  # noqa: BLE001 - a truncated or damaged record
            raise DataError(f"{self.src}: cannot read message {k + 1} on {self.topic} ({short_error(e)})") from None

    def close(self) -> None:
        try:
            self.reader.close()
        except Exception:  # noqa: BLE001, S110 - closing after an error: the first error is the one to tell
            pass


def bag_chunks(path: Path, n: int, opts: DataOptions) -> Iterator[tuple[np.ndarray, dict]]:
    """Chunks of opts.chunk_rows messages: a table of t, q, [dq], tau and its layout (``tables.column_layout``)."""
    from minparam_cli.measured.tables import column_layout

    names = tuple(opts.joint_names)
    if len(names) != n:
        raise DataError(f"{path}: a bag's joints are matched by name; the robot's {n} joint names are needed")
    bag = _Bag(Path(path), opts)
    src, topic = bag.src, bag.topic
    try:
        columns: dict[tuple, np.ndarray] = {}  # the names of a message -> where each robot joint is in its arrays
        table: np.ndarray | None = None
        layout: dict = {}
        width, has_dq = 0, False
        rows = 0
        for k, msg in bag.messages():
            key = tuple(msg.name)
            where = columns.get(key)
            if where is None:
                where = columns[key] = _match(key, names, src, topic, k)
            pos, vel, eff = msg.position, msg.velocity, msg.effort
            if len(pos) != len(key):
                raise DataError(f"{src}: message {k} on {topic} has {len(key)} names and {len(pos)} positions")
            if table is None:
                if len(eff) == 0:
                    raise DataError(f"{src}: message 1 on {topic} has no effort (the joint torques); expected one a joint")
                has_dq = len(vel) > 0
                layout = column_layout({"t": True, "q": True, "dq": has_dq, "ddq": False, "tau": True}, n)
                width = 1 + n * (3 if has_dq else 2)
                table = np.empty((opts.chunk_rows, width))
            row = table[rows]
            stamp = msg.header.stamp
            row[0] = (int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)) / 1e9
            row[layout["q"]] = pos[where]
            for key_name, values in (("dq", vel), ("tau", eff)):
                if key_name == "dq" and not has_dq:
                    continue
                if len(values) == len(key):
                    row[layout[key_name]] = values[where]
                elif len(values) == 0:
                    row[layout[key_name]] = np.nan  # this message lacks them: a NaN row, dropped and counted
                else:
                    what = "velocities" if key_name == "dq" else "efforts"
                    raise DataError(f"{src}: message {k} on {topic} has {len(key)} names and {len(values)} {what}")
            rows += 1
            if rows == opts.chunk_rows:
                yield table, layout
                table, rows = np.empty((opts.chunk_rows, width)), 0
        if table is None:
            raise DataError(f"{src}: no messages on {topic}")
        if rows:
            yield table[:rows], layout
    finally:
        bag.close()


def _match(names: tuple[str, ...], joints: tuple[str, ...], src: str, topic: str, k: int) -> np.ndarray:
    """Index, in a message's arrays, of each robot joint (by name)."""
    at = {name: i for i, name in enumerate(names)}
    missing = [j for j in joints if j not in at]
    if missing:
        shown = ", ".join(missing[:4]) + (", ..." if len(missing) > 4 else "")
        has = ", ".join(names[:6]) + (", ..." if len(names) > 6 else "")
        raise DataError(f"{src}: message {k} on {topic} lacks joint{'s' if len(missing) > 1 else ''} {shown} "
                        f"of the robot (it names: {has or 'none'})")
    if len(at) != len(names):
        raise DataError(f"{src}: message {k} on {topic} names a joint twice")
    return np.array([at[j] for j in joints], dtype=np.intp)


def bag_time_span(path: Path, n: int, opts: DataOptions) -> tuple[float, float]:
    """First and last header stamp (s) of the topic: the stamps alone are read (not decoded
    messages), streamed.  The first is the first message's; the last is the largest."""
    bag = _Bag(Path(path), opts)
    first = last = None
    try:
        for ns in bag.stamps():
            if first is None:
                first = ns
            last = ns if last is None else max(last, ns)
    finally:
        bag.close()
    if first is None or last is None or last <= first:
        raise DataError(f"{path}: fewer than two time stamps on {bag.topic}")
    return first / 1e9, last / 1e9
