"""An MCAP file from whole columns of messages at once (used by :mod:`.mcap_log`).

``mcap.writer.Writer`` takes one message per Python call (about 10 to 30 us each: a writing run
of 20,000 rows on ten topics would spend seconds there). Here the data section is laid out with
numpy instead: every message of a topic has one size, so a run's Message records are one
(rows, bytes) matrix, and the per-chunk MessageIndex records are arrays of (log time, offset)
pairs. Everything else (Header, Schema, Channel, Chunk, ChunkIndex, Statistics, Metadata, the
summary and its offsets, the Footer and its CRC) is written by the ``mcap`` package's own record
classes, in the order ``Writer.finish`` writes them. The files are read back by rosbags and by
mcap's reader in tests/python/test_mcap.py.
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import IO

import numpy as np

__all__ = ["CHUNK_BYTES", "Stream", "write_container"]

#: Uncompressed size a chunk is filled to (the last one may be smaller).
CHUNK_BYTES = 4 << 20
_MAGIC = struct.pack("<8B", 137, 77, 67, 65, 80, 48, 13, 10)
_MESSAGE_HEAD = 1 + 8 + 2 + 4 + 8 + 8     # opcode, length, channel, sequence, log, publish time


@dataclass(frozen=True)
class Stream:
    """One channel's messages, one per row: ``data`` (rows, size) bytes."""

    channel_id: int
    data: np.ndarray


def _message_records(streams: Sequence[Stream], ns: np.ndarray) -> tuple[np.ndarray, list[int]]:
    """The Message records of every row, the streams' records side by side in one row (so the
    data section is in time order), and each stream's offset inside a row."""
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


def write_container(out: IO[bytes], *, profile: str, library: str,
                    schemas: Sequence[tuple[int, str, str, bytes]],
                    channels: Sequence[tuple[int, str, str, int, Mapping[str, str]]],
                    first: Sequence[tuple[int, int, bytes]], ns: np.ndarray,
                    streams: Sequence[Stream], metadata: Mapping[str, Mapping[str, str]]
                    ) -> None:
    """Write an MCAP file: ``schemas`` (id, name, encoding, data), ``channels`` (id, topic,
    message encoding, schema id, metadata), ``first``: single messages (channel, log time,
    data) put at the start of the first chunk, then one message of each stream per row at the
    log (and publish) times ``ns`` (non-decreasing, uint64 ns), ``metadata`` records by name.
    Chunks are compressed with zstd (the ``zstandard`` package, a dependency of ``mcap``)."""
    from mcap.data_stream import RecordBuilder
    from mcap.opcode import Opcode
    from mcap.records import (
        Channel,
        Chunk,
        ChunkIndex,
        DataEnd,
        Footer,
        Header,
        Message,
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
    ns = np.asarray(ns, dtype=np.uint64)
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
    rows, starts = _message_records(streams, ns)
    row_bytes = rows.shape[1] if streams else 0
    per_chunk = max(1, CHUNK_BYTES // max(1, row_bytes))
    counts: dict[int, int] = {c[0]: 0 for c in channels}
    chunk_indexes = []
    n = ns.shape[0]
    for lo in range(0, max(n, 1), per_chunk):
        hi = min(n, lo + per_chunk)
        head = b"".join(record(Message(channel_id=c, log_time=t, data=d, publish_time=t,
                                       sequence=0)) for c, t, d in first) if lo == 0 else b""
        times = [t for _, t, _ in first] if lo == 0 else []
        if hi > lo:
            times += [int(ns[lo:hi].min()), int(ns[lo:hi].max())]
        if not times:
            break
        body = head + rows[lo:hi].tobytes()
        indexes: list[tuple[int, bytes]] = []
        offset = 0
        for c, t, d in (first if lo == 0 else []):
            indexes.append((c, _message_index(c, np.array([t]), np.array([offset]))))
            offset += _MESSAGE_HEAD + len(d)
            counts[c] += 1
        base = len(head) + np.arange(hi - lo, dtype=np.uint64) * np.uint64(row_bytes)
        for s, start in zip(streams, starts, strict=True):
            indexes.append((s.channel_id, _message_index(s.channel_id, ns[lo:hi],
                                                         base + np.uint64(start))))
            counts[s.channel_id] += hi - lo
        packed = pack(body)
        chunk = record(Chunk(compression="zstd", data=packed, message_start_time=min(times),
                             message_end_time=max(times), uncompressed_crc=zlib.crc32(body),
                             uncompressed_size=len(body)))
        chunk_start = put(chunk)
        index_offsets: dict[int, int] = {}
        index_start = pos
        for c, data in indexes:
            index_offsets[c] = put(data)
        chunk_indexes.append(ChunkIndex(
            message_start_time=min(times), message_end_time=max(times),
            chunk_start_offset=chunk_start, chunk_length=len(chunk),
            message_index_offsets=index_offsets, message_index_length=pos - index_start,
            compression="zstd", compressed_size=len(packed), uncompressed_size=len(body)))
    metadata_indexes = []
    for name, values in metadata.items():
        data = record(Metadata(name=name, metadata=dict(values)))
        metadata_indexes.append(MetadataIndex(offset=put(data), length=len(data), name=name))
    put(record(DataEnd(data_section_crc=0)))
    all_times = [t for _, t, _ in first] + ([int(ns.min()), int(ns.max())] if n else [])
    stats = Statistics(
        message_count=sum(counts.values()), schema_count=len(schema_recs),
        channel_count=len(channel_recs), attachment_count=0,
        metadata_count=len(metadata_indexes), chunk_count=len(chunk_indexes),
        message_start_time=min(all_times, default=0), message_end_time=max(all_times, default=0),
        channel_message_counts=counts)
    summary_start = pos
    summary = b""
    offsets = []
    for opcode, recs in ((Opcode.SCHEMA, schema_recs), (Opcode.CHANNEL, channel_recs),
                         (Opcode.STATISTICS, [stats]), (Opcode.CHUNK_INDEX, chunk_indexes),
                         (Opcode.METADATA_INDEX, metadata_indexes)):
        group = b"".join(record(r) for r in recs)
        offsets.append(SummaryOffset(group_opcode=opcode, group_start=summary_start + len(summary),
                                     group_length=len(group)))
        summary += group
    summary_offset_start = summary_start + len(summary)
    summary += b"".join(record(o) for o in offsets)
    crc = zlib.crc32(summary)
    crc = zlib.crc32(struct.pack("<BQQQ", Opcode.FOOTER, 8 + 8 + 4, summary_start,
                                 summary_offset_start), crc)
    put(summary)
    put(record(Footer(summary_start=summary_start, summary_offset_start=summary_offset_start,
                      summary_crc=crc)))
    put(_MAGIC)
