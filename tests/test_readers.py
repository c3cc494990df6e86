"""The one dispatch over data formats (measured/readers.py): the reader follows the path, data held in
memory under a name come first, and every reader gives chunks and a time span."""

from __future__ import annotations

import numpy as np
import pytest

from minparam_cli.measured import readers
from minparam_cli.measured.arrays import as_record, registered
from minparam_cli.measured.records import DataOptions


@pytest.mark.parametrize(
    "name, kind",
    [
        ("run.csv", readers.Csv),
        ("run.CSV", readers.Csv),
        ("run.txt", readers.Csv),  # any other name is read as CSV
        ("run.npz", readers.Npz),
        ("run.NPZ", readers.Npz),
        ("run.parquet", readers.Parquet),
        ("run.mcap", readers.Bag),
        ("run.db3", readers.Bag),
        ("run.bag", readers.Bag),
        ("tx40.recording.yaml", readers.Recording),
        ("tx40.yml", readers.Recording),
        ("metadata.yaml", readers.Csv),  # a rosbag2 folder's file, not a description
    ],
)
def test_the_reader_follows_the_name(tmp_path, name, kind):
    assert isinstance(readers.reader_for(tmp_path / name), kind)


def test_a_rosbag2_folder_is_a_bag(tmp_path):
    (tmp_path / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    assert isinstance(readers.reader_for(tmp_path), readers.Bag)
    assert isinstance(readers.reader_for(tmp_path.parent / "plain_folder"), readers.Csv)


def test_data_held_in_memory_come_before_the_name():
    t = np.arange(5) * 10.0
    record = as_record({"t": t, "q": np.zeros((5, 2)), "tau": np.ones((5, 2))}, "<data>.npz")
    assert isinstance(readers.reader_for("<data>.npz"), readers.Npz)
    with registered([record]):
        reader = readers.reader_for("<data>.npz")
        assert isinstance(reader, readers.InMemory)
        opts = DataOptions(time_unit="ms", joint_names=("a", "b"))
        assert reader.time_span("<data>.npz", opts) == (0.0, 0.04)
        (table, layout), = reader.chunks("<data>.npz", 2, opts)
    assert table[:, 0].tolist() == (t / 1000).tolist() and layout["tau"] == slice(3, 5)


def test_every_reader_gives_chunks_and_a_time_span():
    for _, reader in readers.READERS:
        assert callable(reader.chunks) and callable(reader.time_span)
