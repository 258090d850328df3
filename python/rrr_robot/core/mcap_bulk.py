"""An MCAP file from whole columns of messages at once (used by :mod:`.mcap_log`).

``mcap.writer.Writer`` takes one message per Python call (about 10 to 30 us each: a writing run
of 20,000 rows on ten topics would spend seconds there). Here the data section is laid out with
numpy instead: every message of a topic has one size, so a run's Message records are one
(rows, bytes) matrix, and the per-chunk MessageIndex records are arrays of (log time, offset)
pairs. Everything else (Header, Schema, Channel, Chunk, ChunkIndex, Statistics, Metadata, the
summary and its offsets, the Footer and its CRC) is written by the ``mcap`` package's own record
classes, in the order ``Writer.finish`` writes them. Several blocks of streams, each on its own
time base (the rows of a run, the frames of a CAN log), are merged in time order by one stable
sort of their rows. The files are read back by rosbags and by mcap's readers in
tests/python/jobs/test_mcap.py.
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import IO

import numpy as np

__all__ = ["CHUNK_BYTES", "Block", "Stream", "write_container"]

#: Uncompressed size a chunk is filled to (the last one may be smaller).
CHUNK_BYTES = 4 << 20
_MAGIC = struct.pack("<8B", 137, 77, 67, 65, 80, 48, 13, 10)
_MESSAGE_HEAD = 1 + 8 + 2 + 4 + 8 + 8     # opcode, length, channel, sequence, log, publish time


@dataclass(frozen=True)
class Stream:
    """One channel's messages, one per row of its block: ``data`` (rows, size) bytes."""

    channel_id: int
    data: np.ndarray


@dataclass(frozen=True)
class Block:
    """Streams that share their log (and publish) times ``ns`` (one per row, uint64 ns)."""

    ns: np.ndarray
    streams: Sequence[Stream]


def _message_records(streams: Sequence[Stream], ns: np.ndarray) -> tuple[np.ndarray, list[int]]:
    """The Message records of every row, the streams' records side by side in one row, and each
    stream's offset inside a row."""
    n = ns.shape[0]
    parts, starts, start = [], [], 0
    for s in streams:
        size = s.data.shape[1]
        rec = np.empty((n, _MESSAGE_HEAD + size), dtype=np.uint8)
        rec[:, 0] = 0x05
        rec[:, 1:9].view("<u8")[:, 0] = 2 + 4 + 8 + 8 + size
        rec[:, 9:11].view("<u2")[:, 0] = s.channel_id
        rec[:, 11:15].view("<u4")[:, 0] = np.arange(n, dtype=np.uint64) & 0xFFFFFFFF
        rec[:, 15:23].view("<u8")[:, 0] = ns
        rec[:, 23:31].view("<u8")[:, 0] = ns
        rec[:, 31:] = s.data
        parts.append(rec)
        starts.append(start)
        start += rec.shape[1]
    return np.concatenate(parts, axis=1), starts


def _message_index(channel_id: int, times: np.ndarray, offsets: np.ndarray) -> bytes:
    pairs = np.empty((times.shape[0], 2), dtype="<u8")
    pairs[:, 0], pairs[:, 1] = times, offsets
    body = pairs.tobytes()
    return struct.pack("<BQHI", 0x07, 2 + 4 + len(body), channel_id, len(body)) + body


def _data_section(blocks: Sequence[Block]) -> tuple[
        np.ndarray, np.ndarray, np.ndarray, list[tuple[int, np.ndarray, np.ndarray]]]:
    """Every block's rows merged in time order (a stable sort: equal times keep the blocks'
    order) into one byte array; the start of each row there (increasing) and its time; and per
    stream (channel, times, record offsets)."""
    rows, times, sizes, owners = [], [], [], []
    for b, block in enumerate(blocks):
        ns = np.asarray(block.ns, dtype=np.uint64)
        mat, starts = _message_records(block.streams, ns)
        rows.append((mat, starts, ns))
        times.append(ns)
        sizes.append(np.full(ns.shape[0], mat.shape[1], dtype=np.uint64))
        owners.append(np.full(ns.shape[0], b))
    all_times = np.concatenate(times)
    order = np.argsort(all_times, kind="stable")
    sorted_sizes = np.concatenate(sizes)[order]
    row_start = np.zeros(order.shape[0], dtype=np.uint64)
    np.cumsum(sorted_sizes[:-1], out=row_start[1:])
    where = np.empty_like(row_start)
    where[order] = row_start                      # each row's start, in the blocks' own order
    buffer = np.empty(int(sorted_sizes.sum()), dtype=np.uint8)
    indexes: list[tuple[int, np.ndarray, np.ndarray]] = []
    first = 0
    for (mat, starts, ns), block in zip(rows, blocks, strict=True):
        pos = where[first:first + ns.shape[0]]
        first += ns.shape[0]
        buffer[pos.astype(np.int64)[:, None] + np.arange(mat.shape[1])] = mat
        for s, start in zip(block.streams, starts, strict=True):
            indexes.append((s.channel_id, ns, pos + np.uint64(start)))
    return buffer, row_start, all_times[order], indexes


def write_container(out: IO[bytes], *, profile: str, library: str,
                    schemas: Sequence[tuple[int, str, str, bytes]],
                    channels: Sequence[tuple[int, str, str, int, Mapping[str, str]]],
                    blocks: Sequence[Block], metadata: Mapping[str, Mapping[str, str]]
                    ) -> None:
    """Write an MCAP file: ``schemas`` (id, name, encoding, data), ``channels`` (id, topic,
    message encoding, schema id, metadata), the messages of ``blocks`` in time order, and
    ``metadata`` records by name. Chunks are compressed with zstd (the ``zstandard`` package,
    a dependency of ``mcap``)."""
    from mcap.data_stream import RecordBuilder
    from mcap.opcode import Opcode
    from mcap.records import (
        Channel,
        Chunk,
        ChunkIndex,
        DataEnd,
        Footer,
        Header,
        Metadata,
        MetadataIndex,
        Schema,
        Statistics,
        SummaryOffset,
    )

    def record(rec: object) -> bytes:
        builder = RecordBuilder()
        rec.write(builder)  # type: ignore[attr-defined]
        return bytes(builder.end())  # type: ignore[no-untyped-call]

    import zstandard

    pack = zstandard.ZstdCompressor().compress
    pos = 0

    def put(data: bytes) -> int:
        nonlocal pos
        start = pos
        out.write(data)
        pos += len(data)
        return start

    schema_recs = [Schema(id=i, name=name, encoding=enc, data=data)
                   for i, name, enc, data in schemas]
    channel_recs = [Channel(id=i, topic=topic, message_encoding=enc, schema_id=sid,
                            metadata=dict(meta)) for i, topic, enc, sid, meta in channels]
    put(_MAGIC)
    put(record(Header(profile=profile, library=library)))
    for rec in (*schema_recs, *channel_recs):
        put(record(rec))
    data, row_start, row_time, streams = _data_section(blocks)
    counts: dict[int, int] = {c[0]: 0 for c in channels}
    for channel_id, ns, _ in streams:
        counts[channel_id] += ns.shape[0]
    # chunk boundaries at the first row starting in each CHUNK_BYTES of the data
    cut = np.flatnonzero(np.diff(row_start // np.uint64(CHUNK_BYTES), prepend=np.uint64(1 << 62)))
    bounds = [*row_start[cut].tolist(), data.shape[0]]
    ends = [*cut[1:].tolist(), row_start.shape[0]]
    chunk_indexes = []
    for k in range(len(bounds) - 1):
        lo, hi = int(bounds[k]), int(bounds[k + 1])
        body = data[lo:hi].tobytes()
        t_lo, t_hi = int(row_time[cut[k]]), int(row_time[ends[k] - 1])
        packed = pack(body)
        chunk = record(Chunk(compression="zstd", data=packed, message_start_time=t_lo,
                             message_end_time=t_hi, uncompressed_crc=zlib.crc32(body),
                             uncompressed_size=len(body)))
        chunk_start = put(chunk)
        index_offsets: dict[int, int] = {}
        index_start = pos
        for channel_id, ns, offsets in streams:
            a, b = np.searchsorted(offsets, [lo, hi])
            if b > a:
                index_offsets[channel_id] = put(_message_index(
                    channel_id, ns[a:b], offsets[a:b] - np.uint64(lo)))
        chunk_indexes.append(ChunkIndex(
            message_start_time=t_lo, message_end_time=t_hi, chunk_start_offset=chunk_start,
            chunk_length=len(chunk), message_index_offsets=index_offsets,
            message_index_length=pos - index_start, compression="zstd",
            compressed_size=len(packed), uncompressed_size=len(body)))
    metadata_indexes = []
    for name, values in metadata.items():
        meta = record(Metadata(name=name, metadata=dict(values)))
        metadata_indexes.append(MetadataIndex(offset=put(meta), length=len(meta), name=name))
    put(record(DataEnd(data_section_crc=0)))
    stats = Statistics(
        message_count=sum(counts.values()), schema_count=len(schema_recs),
        channel_count=len(channel_recs), attachment_count=0,
        metadata_count=len(metadata_indexes), chunk_count=len(chunk_indexes),
        message_start_time=int(row_time[0]) if row_time.size else 0,
        message_end_time=int(row_time[-1]) if row_time.size else 0,
        channel_message_counts=counts)
    summary_start = pos
    summary = b""
    groups = []
    for opcode, recs in ((Opcode.SCHEMA, schema_recs), (Opcode.CHANNEL, channel_recs),
                         (Opcode.STATISTICS, [stats]), (Opcode.CHUNK_INDEX, chunk_indexes),
                         (Opcode.METADATA_INDEX, metadata_indexes)):
        group = b"".join(record(r) for r in recs)
        groups.append(SummaryOffset(group_opcode=opcode, group_start=summary_start + len(summary),
                                    group_length=len(group)))
        summary += group
    summary_offset_start = summary_start + len(summary)
    summary += b"".join(record(o) for o in groups)
    crc = zlib.crc32(summary)
    crc = zlib.crc32(struct.pack("<BQQQ", Opcode.FOOTER, 8 + 8 + 4, summary_start,
                                 summary_offset_start), crc)
    put(summary)
    put(record(Footer(summary_start=summary_start, summary_offset_start=summary_offset_start,
                      summary_crc=crc)))
    put(_MAGIC)
