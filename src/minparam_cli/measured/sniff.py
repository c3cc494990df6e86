"""A data file that is not CSV text, told by its first bytes: a compressed file or an archive under a
.csv name, UTF-16 text, another binary format.  Refused in one line that says what it is, before a
parser reads it as text and reports its bytes as a strange header."""

from __future__ import annotations

from pathlib import Path

from minparam_cli.errors import DataError

# (leading bytes, what the file is)
MAGIC = (
    (b"\x1f\x8b", "a gzip-compressed file (decompress it first, e.g. with gunzip)"),
    (b"\xfd7zXZ\x00", "an xz-compressed file (decompress it first, e.g. with unxz)"),
    (b"\x28\xb5\x2f\xfd", "a zstd-compressed file (decompress it first, e.g. with unzstd)"),
    (b"PK\x03\x04", "a zip archive (an .npz file? name it .npz; else unzip it first)"),
    (b"\xff\xfe", "UTF-16 text (save it as UTF-8)"),
    (b"\xfe\xff", "UTF-16 text (save it as UTF-8)"),
    (b"\x93NUMPY", "a numpy .npy array (save the arrays with numpy.savez as .npz)"),
    (b"\x89HDF\r\n", "an HDF5 file"),
)
BZIP2 = (b"BZh", b"1AY&SY")  # "BZh", a block size digit, the first block's magic
PARQUET = b"PAR1"  # at both ends of a Parquet file (a CSV's first column may be named PAR1...)


def what_binary(head: bytes, tail: bytes = b"") -> str | None:
    """What a file starting with ``head`` (and ending with ``tail``) is, when it is one of the formats
    above or Parquet; None otherwise."""
    if head.startswith(PARQUET) and tail.endswith(PARQUET):
        return "a Parquet file (name it .parquet)"
    for magic, what in MAGIC:
        if head.startswith(magic):
            return what
    if head.startswith(BZIP2[0]) and head[3:4].isdigit() and head[4:10] == BZIP2[1]:
        return "a bzip2-compressed file (decompress it first, e.g. with bunzip2)"
    return None


def refuse_binary(path: Path) -> None:
    """The one-line DataError for a data file read as CSV text that is one of the formats above."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(16)
            tail = b""
            if head.startswith(PARQUET) and fh.seek(0, 2) >= 2 * len(PARQUET):
                fh.seek(-len(PARQUET), 2)
                tail = fh.read(len(PARQUET))
    except OSError as e:
        raise DataError(f"{path}: cannot read file ({e.strerror})") from None
    what = what_binary(head, tail)
    if what is not None:
        raise DataError(f"{path}: not CSV text but {what}")
