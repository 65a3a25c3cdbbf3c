"""MCAP recordings of the Zenoh traffic: the exact wire bytes, one channel per key.

Writing (:class:`Recorder`): each message goes to the channel of its (key, Zenoh
encoding); channels carry the encoding in their metadata and the JSON Schema of
the message type (``protocols.codec.json_schema``) as their schema, named
``gcs.<Type>/<version>``. ``log_time`` is the receive time and ``publish_time``
the message's ``stamp_ns`` (the receive time when the payload has none).
Liveliness changes are recorded too, on the token's key with the encoding
:data:`LIVELINESS_ENCODING` and payload ``alive`` or ``gone``; so are the MAVLink
heartbeats the daemon hears (a vehicle is alive by its token or its heartbeat, and
``gcs replay --process`` must see what the daemon saw), on the vehicle's liveliness
key with the encoding :data:`HEARTBEAT_ENCODING` and payload ``heartbeat``. The run's
scenario, when the writer knows it, is an MCAP metadata record :data:`SCENARIO_METADATA`
(``name`` and ``fingerprint``, :func:`gcs.config.fingerprint.scenario_fingerprint`).
Chunks are small (:data:`CHUNK_BYTES`) and flushed as they fill, so a writer that is
killed loses at most the last chunk; :meth:`Recorder.finish` writes the summary.

Reading (:func:`read_recording`): records are read in file order (the order
they were received) with a streaming reader (metadata records go to a callback),
so a file without a summary (its writer was killed) is recovered up to its last
complete chunk, with a warning.
A file that does not begin with MCAP's magic bytes (empty, or not MCAP at all)
raises :class:`RecordingError` before anything is read.
A schema this build does not speak, or a corrupt record, raises
:class:`RecordingError` naming the channel and the byte offset; nothing is
skipped silently.
"""

from __future__ import annotations

import io
import logging
import struct
import zlib
from collections.abc import Callable, Generator
from dataclasses import dataclass
from pathlib import Path

import msgspec
import lz4.frame
import zstandard
from mcap.data_stream import ReadDataStream
from mcap.exceptions import EndOfFile, McapError
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, Footer, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from gcs.config import Scenario
from gcs.config.fingerprint import scenario_fingerprint
from protocols.codec import json_schema, wire_version
from protocols.errors import ProtocolError

__all__ = ["CHUNK_BYTES", "HEARTBEAT_ENCODING", "LIVELINESS_ENCODING", "MCAP_MAGIC", "SCENARIO_METADATA", "Recorded",
           "Recorder", "RecordingError", "read_recording", "check_mcap"]

log = logging.getLogger(__name__)

MCAP_MAGIC = b"\x89MCAP0\r\n"
"""The bytes every MCAP file begins with."""
CHUNK_BYTES = 64 * 1024
"""Chunk size: at most this much is lost when the writer is killed."""
LIVELINESS_ENCODING = "gcs/liveliness"
"""Encoding of recorded liveliness changes (payload ``alive`` or ``gone``)."""
HEARTBEAT_ENCODING = "gcs/heartbeat"
"""Encoding of a recorded MAVLink heartbeat from a vehicle (payload ``heartbeat``, on its liveliness key)."""
SCENARIO_METADATA = "gcs.scenario"
"""Name of the metadata record holding the run's scenario: ``{"name": ..., "fingerprint": ...}``."""
MESSAGE_ENCODING = "json"
SCHEMA_ENCODING = "jsonschema"


class RecordingError(ValueError):
    """A recording that cannot be read as it is; the message names the file, channel and offset."""


class _Stamped(msgspec.Struct):
    stamp_ns: int


_stamp_decoder = msgspec.json.Decoder(_Stamped)


def _stamp(payload: bytes, default: int) -> int:
    try:
        stamp = _stamp_decoder.decode(payload).stamp_ns
    except (msgspec.DecodeError, msgspec.ValidationError):
        return default
    return stamp if 0 <= stamp < 2**64 else default


@dataclass(frozen=True)
class Recorded:
    """One recorded message: its key, exact payload and encoding, times, and where it is in the file."""

    key: str
    payload: bytes
    encoding: str
    log_time_ns: int
    publish_time_ns: int
    channel_id: int
    offset: int


class Recorder:
    """Writes an MCAP file; see the module docstring. Use as a context manager or call :meth:`finish`."""

    def __init__(self, path: str | Path, library: str = "gcs", scenario: Scenario | None = None) -> None:
        """``scenario``: the run's, recorded at once (:meth:`write_scenario`), when the writer knows it."""
        self.path = Path(path)
        self._file = open(self.path, "wb")
        self._writer = Writer(self._file, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)
        self._writer.start(profile="", library=library)
        self._schemas: dict[str, int] = {}
        self._channels: dict[tuple[str, str], int] = {}
        self._sequence: dict[int, int] = {}
        self._written_at_flush = 0
        self.messages = 0
        self.scenario: tuple[str, str] | None = None
        self.finished = False
        if scenario is not None:
            self.write_scenario(scenario.name, scenario_fingerprint(scenario))

    def _schema_id(self, encoding: str) -> int:
        if encoding in (LIVELINESS_ENCODING, HEARTBEAT_ENCODING):
            return 0
        try:
            message_type, version = wire_version(encoding)
        except ProtocolError:
            return 0  # recorded as received, without a schema: replay and --process reject it as the daemon did
        name = f"gcs.{message_type.__name__}/{version}"
        if name not in self._schemas:
            self._schemas[name] = self._writer.register_schema(name, SCHEMA_ENCODING, json_schema(message_type, version))
        return self._schemas[name]

    def write(self, key: str, payload: bytes, encoding: str, log_time_ns: int) -> None:
        """Record one message as received (exact bytes)."""
        channel = self._channels.get((key, encoding))
        if channel is None:
            channel = self._writer.register_channel(key, MESSAGE_ENCODING, self._schema_id(encoding),
                                                    metadata={"zenoh_encoding": encoding})
            self._channels[(key, encoding)] = channel
        sequence = self._sequence.get(channel, 0) + 1
        self._sequence[channel] = sequence
        publish = log_time_ns if encoding == LIVELINESS_ENCODING else _stamp(payload, log_time_ns)
        self._writer.add_message(channel, log_time=log_time_ns, data=payload, publish_time=publish,
                                 sequence=sequence & 0xFFFFFFFF)
        self.messages += 1
        if self._file.tell() != self._written_at_flush:  # a chunk was written: get it to disk
            self._file.flush()
            self._written_at_flush = self._file.tell()

    def write_liveliness(self, key: str, alive: bool, log_time_ns: int) -> None:
        """Record a liveliness token appearing or going."""
        self.write(key, b"alive" if alive else b"gone", LIVELINESS_ENCODING, log_time_ns)

    def write_heartbeat(self, key: str, log_time_ns: int) -> None:
        """Record a MAVLink heartbeat heard from the vehicle whose liveliness key is ``key``."""
        self.write(key, b"heartbeat", HEARTBEAT_ENCODING, log_time_ns)

    def write_scenario(self, name: str, fingerprint: str) -> None:
        """Record the run's scenario (a metadata record :data:`SCENARIO_METADATA`); only the first is kept."""
        if self.scenario is None:
            self.scenario = (name, fingerprint)
            self._writer.add_metadata(SCENARIO_METADATA, {"name": name, "fingerprint": fingerprint})

    def finish(self) -> None:
        """Write the summary and close the file (idempotent)."""
        if not self.finished:
            self._writer.finish()
            self._file.close()
            self.finished = True

    def __enter__(self) -> Recorder:
        return self

    def __exit__(self, *exc) -> None:
        self.finish()


class _CountingReader(io.RawIOBase):
    """A file wrapper that knows how many bytes have been read (the offset of the next record)."""

    def __init__(self, raw) -> None:
        self.raw, self.position = raw, 0

    def readable(self) -> bool:
        return True

    def readinto(self, buffer) -> int:
        count = self.raw.readinto(buffer)
        self.position += count or 0
        return count

    def read(self, size: int = -1) -> bytes:
        data = self.raw.read(size)
        self.position += len(data)
        return data


def read_recording(path: str | Path, warn: Callable[[str], None] = log.warning,
                   on_metadata: Callable[[str, dict[str, str]], None] | None = None) -> Generator[Recorded, None, None]:
    """Every message of a recording in file order; see the module docstring for errors and recovery.
    ``on_metadata(name, data)`` is called with each metadata record as it is read.

    Chunks are decompressed and their records split here (:func:`_chunk_records`)
    rather than by the ``mcap`` library's record-by-record reader: the messages
    are simple fixed-layout records and this is several times faster, which is
    most of ``gcs replay --process``'s time otherwise.
    """
    path = Path(path)
    check_mcap(path)
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    with open(path, "rb") as raw:
        stream = _CountingReader(raw)
        records = StreamReader(stream, skip_magic=False, emit_chunks=True).records
        count, footer = 0, False
        while True:
            offset = stream.position
            try:
                record = next(records)
            except StopIteration:
                break
            except (EndOfFile, McapError, ValueError, KeyError, struct.error) as error:
                if isinstance(error, EndOfFile) or not raw.read(1):  # the file ends inside this record
                    warn(f"{path}: the recording ends without a summary at byte {offset} (its writer was "
                         f"killed?); recovered {count} messages up to the last complete chunk")
                    return
                raise RecordingError(f"{path}: corrupt record at byte offset {offset}: {error}") from error
            inner = _chunk_records(path, record, offset) if isinstance(record, Chunk) else [record]
            for item in inner:
                if isinstance(item, Schema):
                    schemas[item.id] = item
                elif isinstance(item, Channel):
                    channels[item.id] = _checked_channel(path, item, schemas, offset)
                elif isinstance(item, tuple):  # a message from a chunk: (channel, sequence, log, publish, data)
                    channel = channels.get(item[0])
                    if channel is None:
                        raise RecordingError(f"{path}: message in the chunk at byte offset {offset} names unknown "
                                             f"channel {item[0]}")
                    count += 1
                    yield Recorded(channel.topic, item[4], channel.metadata.get("zenoh_encoding", ""),
                                   item[2], item[3], item[0], offset)
                elif isinstance(item, Message):
                    channel = channels.get(item.channel_id)
                    if channel is None:
                        raise RecordingError(f"{path}: message at byte offset {offset} names unknown channel "
                                             f"{item.channel_id}")
                    count += 1
                    yield Recorded(channel.topic, item.data, channel.metadata.get("zenoh_encoding", ""),
                                   item.log_time, item.publish_time, item.channel_id, offset)
                elif isinstance(item, Metadata) and on_metadata is not None:
                    on_metadata(item.name, dict(item.metadata))
                elif isinstance(item, Footer):
                    footer = True
        if not footer:
            warn(f"{path}: no footer; recovered {count} messages")


def check_mcap(path: Path) -> None:
    """RecordingError unless ``path`` begins with MCAP's magic bytes (OSError when it cannot be read)."""
    with open(path, "rb") as raw:
        head = raw.read(len(MCAP_MAGIC))
    if not head:
        raise RecordingError(f"{path}: the file is empty: nothing was recorded in it")
    if head != MCAP_MAGIC:
        raise RecordingError(f"{path}: not an MCAP recording (it does not begin with MCAP's magic bytes); give a "
                             "file written by gcs record or gcs run --record")


_MESSAGE_HEADER = struct.Struct("<HIQQ")  # channel id, sequence, log time, publish time


def _chunk_records(path: Path, chunk: Chunk, offset: int) -> list:
    """Schemas, channels and messages (as tuples) of one chunk, CRC-checked."""
    try:
        if chunk.compression == "zstd":
            data = zstandard.ZstdDecompressor().decompress(chunk.data, max_output_size=chunk.uncompressed_size)
        elif chunk.compression == "lz4":
            data = lz4.frame.decompress(chunk.data)
        elif chunk.compression == "":
            data = chunk.data
        else:
            raise RecordingError(f"{path}: chunk at byte offset {offset}: unknown compression {chunk.compression!r}")
    except (zstandard.ZstdError, RuntimeError) as error:
        raise RecordingError(f"{path}: corrupt chunk at byte offset {offset}: {error}") from error
    if chunk.uncompressed_crc and zlib.crc32(data) != chunk.uncompressed_crc:
        raise RecordingError(f"{path}: corrupt chunk at byte offset {offset}: CRC mismatch")
    out: list = []
    position, end = 0, len(data)
    try:
        while position < end:
            opcode = data[position]
            (length,) = struct.unpack_from("<Q", data, position + 1)
            body, position = position + 9, position + 9 + length
            if position > end:
                raise RecordingError(f"{path}: chunk at byte offset {offset}: a record runs past the chunk's end")
            if opcode == Opcode.MESSAGE:
                channel, sequence, log_time, publish_time = _MESSAGE_HEADER.unpack_from(data, body)
                out.append((channel, sequence, log_time, publish_time, data[body + _MESSAGE_HEADER.size:position]))
            elif opcode == Opcode.SCHEMA:
                out.append(Schema.read(ReadDataStream(io.BytesIO(data[body:position]))))
            elif opcode == Opcode.CHANNEL:
                out.append(Channel.read(ReadDataStream(io.BytesIO(data[body:position]))))
    except (struct.error, IndexError, McapError) as error:
        raise RecordingError(f"{path}: corrupt chunk at byte offset {offset}: {error}") from error
    return out


def _checked_channel(path: Path, channel: Channel, schemas: dict[int, Schema], offset: int) -> Channel:
    """A channel whose schema and encoding this build speaks, else RecordingError naming it."""
    encoding = channel.metadata.get("zenoh_encoding")
    where = f"{path}: channel {channel.topic!r} (id {channel.id}) at byte offset {offset}"
    if encoding is None:
        raise RecordingError(f"{where}: no zenoh_encoding in its metadata (not a gcs recording?)")
    if channel.schema_id == 0:
        return channel  # liveliness, heartbeats, or a payload recorded exactly as an unknown encoding arrived
    schema = schemas.get(channel.schema_id)
    if schema is None:
        raise RecordingError(f"{where}: unknown schema id {channel.schema_id}")
    try:
        message_type, version = wire_version(encoding)
    except ProtocolError as error:
        raise RecordingError(f"{where}: {error}") from error
    expected = f"gcs.{message_type.__name__}/{version}"
    if schema.name != expected:
        raise RecordingError(f"{where}: schema {schema.name!r} is not {expected!r}, the version its encoding names")
    return channel
