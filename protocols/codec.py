"""The one codec: message <-> JSON bytes plus the Zenoh encoding string.

The payload is the msgspec JSON encoding of the Struct; the type and its version
travel in the Zenoh encoding ``application/json;gcs.<TypeName>/<VERSION>``.

- :func:`encode` refuses (with :class:`~protocols.errors.ProtocolError`) any message
  that :func:`decode` would reject: it walks the message for non-finite floats first
  (msgspec would silently write them as ``null``), then checks the encoded bytes with
  the same validating decoder the receiver uses (ranges, patterns, size).
- :func:`decode` never raises anything but ProtocolError, whatever the bytes and the
  encoding string; the error names the field (``.field`` holds its msgspec-style
  path, e.g. ``$.prediction[1].position_cov_m2``) and has a ``.reason`` to count by.
- Earlier versions (:data:`protocols.legacy.LEGACY_VERSIONS`) decode too: validated by
  their own rules, then upgraded, so :func:`decode` returns the current type only.
  The version comes from the encoding string; without one, from the payload's fields
  (an earlier version the current one reads as it is decodes as the current one).
  :func:`encode` always writes the current version.
"""

from __future__ import annotations

import math
import re
from typing import TypeVar, overload

import msgspec

from protocols.errors import ProtocolError
from protocols.legacy import LEGACY_VERSIONS, AnyLegacyVersion
from protocols.messages import MESSAGE_TYPES, Message

__all__ = [
    "ENCODING_MEDIA_TYPE",
    "MAX_PAYLOAD_BYTES",
    "SCHEMA_NAMESPACE",
    "decode",
    "encode",
    "encoding_for",
    "json_schema",
    "parse_encoding",
    "wire_version",
]

#: Payloads larger than this are rejected before parsing (and never produced).
MAX_PAYLOAD_BYTES = 64 * 1024
ENCODING_MEDIA_TYPE = "application/json"
SCHEMA_NAMESPACE = "gcs."

M = TypeVar("M", bound=Message)

_TYPES_BY_NAME: dict[str, type[Message]] = {tp.__name__: tp for tp in MESSAGE_TYPES}
_DECODERS: dict[type[Message], msgspec.json.Decoder[Message]] = {
    tp: msgspec.json.Decoder(tp) for tp in MESSAGE_TYPES
}
_LEGACY: dict[tuple[type[Message], int], AnyLegacyVersion] = {(old.current, old.version): old for old in LEGACY_VERSIONS}
_LEGACY_DECODERS: dict[type[Message], msgspec.json.Decoder[Message]] = {
    old.struct: msgspec.json.Decoder(old.struct) for old in LEGACY_VERSIONS
}
_ENCODER = msgspec.json.Encoder()
_VERSION_RE = re.compile(r"[0-9]{1,9}")
_PARSED: dict[str, tuple[type[Message], int]] = {}
"""Encoding strings :func:`wire_version` accepted, and the type and version each names (every message parses one)."""
# The path msgspec appends to a validation error: "... - at `$.a[1]`" or "`key` in `$.d`".
_TRAILING_PATH_RE = re.compile(r"`(\$[^`]*)`$")
_NAMED_FIELD_RE = re.compile(r"^Object (?:missing required|contains unknown) field `([^`]*)`")


def _registered(tp: object) -> type[Message]:
    if not isinstance(tp, type) or tp not in _DECODERS:
        name = getattr(tp, "__name__", repr(tp))
        raise ProtocolError(f"{name} is not a registered message type", reason="unexpected_type")
    return tp


def _encoding_of(tp: type[Message]) -> str:
    return f"{ENCODING_MEDIA_TYPE};{SCHEMA_NAMESPACE}{tp.__name__}/{tp.VERSION}"


_ENCODINGS: dict[type[Message], str] = {tp: _encoding_of(tp) for tp in MESSAGE_TYPES}


def encoding_for(tp: type[Message]) -> str:
    """Zenoh encoding string of a message type, e.g. ``application/json;gcs.SensorReport/1``."""
    encoding = _ENCODINGS.get(tp) if isinstance(tp, type) else None
    return encoding if encoding is not None else _encoding_of(_registered(tp))


def parse_encoding(encoding: str) -> type[Message]:
    """Message type named by a Zenoh encoding string (the current type for an earlier version it reads).

    Raises
    ------
    ProtocolError
        ``reason="encoding"``, saying whether the media type, the ``gcs.`` schema
        namespace, the type name or the version is wrong.
    """
    return wire_version(encoding)[0]


def wire_version(encoding: str) -> tuple[type[Message], int]:
    """Message type and wire version named by a Zenoh encoding string: the current version or
    one of :data:`~protocols.legacy.LEGACY_VERSIONS`.

    Raises
    ------
    ProtocolError
        As :func:`parse_encoding`.
    """
    parsed = _PARSED.get(encoding) if isinstance(encoding, str) else None
    if parsed is not None:
        return parsed
    if not isinstance(encoding, str):
        raise ProtocolError(
            f"encoding must be a str, got {type(encoding).__name__}", reason="encoding"
        )
    media, _, schema = encoding.partition(";")
    if media != ENCODING_MEDIA_TYPE:
        raise ProtocolError(
            f"unsupported encoding {encoding!r}: media type must be {ENCODING_MEDIA_TYPE!r}",
            reason="encoding",
        )
    if not schema.startswith(SCHEMA_NAMESPACE):
        raise ProtocolError(
            f"encoding {encoding!r} lacks the '{SCHEMA_NAMESPACE}<Type>/<version>' schema",
            reason="encoding",
        )
    name, sep, version = schema[len(SCHEMA_NAMESPACE) :].rpartition("/")
    if not sep:
        raise ProtocolError(f"encoding {encoding!r} has no '/<version>'", reason="encoding")
    tp = _TYPES_BY_NAME.get(name)
    if tp is None:
        raise ProtocolError(
            f"unknown message type {name!r} in encoding {encoding!r}", reason="encoding"
        )
    number = int(version) if _VERSION_RE.fullmatch(version) is not None else None
    if number is None or (number != tp.VERSION and (tp, number) not in _LEGACY):
        readable = sorted([tp.VERSION] + [v for (t, v) in _LEGACY if t is tp])
        raise ProtocolError(
            f"unsupported version {version!r} of {name} in encoding {encoding!r} "
            f"(this build speaks version {tp.VERSION}"
            + (f" and reads {', '.join(map(str, readable))})" if len(readable) > 1 else ")"),
            reason="encoding",
        )
    _PARSED[encoding] = (tp, number)  # valid strings only: a few per type (the version may have leading zeros)
    return tp, number


_NULL = b"null"
"""JSON has no NaN or infinity: msgspec writes them as ``null``, as it writes ``None``. A payload
without ``null`` therefore holds only finite floats, and only one with it needs :func:`_check_finite`
(which walks the message and names the first non-finite float's path)."""


def _check_finite(value: object, path: str) -> None:
    """Raise ProtocolError at the first non-finite float inside ``value``."""
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ProtocolError(f"non-finite float {value!r} at `{path}`", field=path)
    elif isinstance(value, msgspec.Struct):
        for name in value.__struct_fields__:
            _check_finite(getattr(value, name), f"{path}.{name}")
    elif isinstance(value, (tuple, list)):
        for i, item in enumerate(value):
            _check_finite(item, f"{path}[{i}]")
    elif isinstance(value, dict):
        for key, item in value.items():
            _check_finite(item, f"{path}[{key!r}]")


def _join_path(outer: str | None, inner: str | None) -> str | None:
    if inner is None:
        return outer
    if outer is None or outer == "$":
        return inner
    return outer + inner[1:]


def _field_of(exc: msgspec.ValidationError) -> str | None:
    """msgspec-style path of the field a ValidationError is about, if it names one."""
    text = str(exc)
    trailing = _TRAILING_PATH_RE.search(text)
    outer = trailing.group(1) if trailing else None
    named = _NAMED_FIELD_RE.match(text)
    inner: str | None = None
    if named:
        inner = f"$.{named.group(1)}"
    else:
        # A __post_init__ error: msgspec keeps the original as __context__ and only
        # appends the path of the enclosing element when the Struct is nested.
        cause = exc.__cause__ or exc.__context__
        if isinstance(cause, ProtocolError):
            inner = cause.field
    return _join_path(outer, inner)


def _decode_as(payload: bytes | bytearray | memoryview, tp: type[Message], name: str | None = None,
               decoder: msgspec.json.Decoder[Message] | None = None) -> Message:
    name = name or tp.__name__
    try:
        return (decoder or _DECODERS[tp]).decode(payload)
    except ProtocolError as exc:  # defensive: msgspec normally wraps ValueErrors
        raise ProtocolError(f"invalid {name}: {exc.message}", field=exc.field) from exc
    except msgspec.ValidationError as exc:
        text = str(exc)
        field = _field_of(exc)
        if field is not None and f"`{field}`" not in text:
            text = f"{text} (field `{field}`)"
        raise ProtocolError(f"invalid {name}: {text}", field=field) from exc
    except msgspec.DecodeError as exc:
        raise ProtocolError(f"malformed {name} payload: {exc}", reason="malformed") from exc
    except Exception as exc:  # RecursionError, MemoryError, errors msgspec does not wrap
        raise ProtocolError(
            f"cannot decode {name} payload: {type(exc).__name__}: {exc}", reason="malformed"
        ) from exc


def _decode_legacy(payload: bytes | bytearray | memoryview, old: AnyLegacyVersion) -> Message:
    """Decode an earlier version by its own rules and upgrade it to the current type."""
    message = _decode_as(payload, old.struct, f"{old.current.__name__}/{old.version}", _LEGACY_DECODERS[old.struct])
    try:
        return old.upgraded(message)
    except ProtocolError as exc:
        raise ProtocolError(f"cannot upgrade {old.current.__name__}/{old.version}: {exc.message}",
                            field=exc.field) from exc


def _decode_any_version(payload: bytes | bytearray | memoryview, tp: type[Message]) -> Message:
    """Without an encoding string: the current version, else an earlier one whose marker field the payload has."""
    try:
        return _decode_as(payload, tp)
    except ProtocolError:
        for (current, _), old in _LEGACY.items():
            if current is tp and old.marker is not None and old.marker in bytes(payload):
                return _decode_legacy(payload, old)
        raise


def encode(msg: Message) -> tuple[bytes, str]:
    """Encode a message for the wire.

    Parameters
    ----------
    msg : Message
        An instance of one of :data:`protocols.messages.MESSAGE_TYPES`.

    Returns
    -------
    payload : bytes
        JSON text (UTF-8), at most MAX_PAYLOAD_BYTES.
    encoding : str
        ``application/json;gcs.<TypeName>/<VERSION>``.

    Raises
    ------
    ProtocolError
        If the type is not registered, a float is NaN or infinite (the path is
        named, e.g. ``$.vehicle_position_enu_m[1]``), a value is outside its range,
        or the payload would exceed MAX_PAYLOAD_BYTES: whatever :func:`decode`
        would reject on the other side.
    """
    tp = _registered(type(msg))
    try:
        payload = _ENCODER.encode(msg)
    except Exception as exc:  # e.g. a numpy array smuggled into a tuple field
        raise ProtocolError(f"cannot encode {tp.__name__}: {exc}") from exc
    if _NULL in payload:  # NaN or an infinity (or only a None, or a string holding "null"): look closer
        _check_finite(msg, "$")
    if len(payload) > MAX_PAYLOAD_BYTES:
        raise ProtocolError(
            f"encoded {tp.__name__} is {len(payload)} bytes, over {MAX_PAYLOAD_BYTES}",
            reason="oversize",
        )
    try:
        _decode_as(payload, tp)
    except ProtocolError as exc:
        raise ProtocolError(
            f"refusing to encode: {exc.message}", field=exc.field, reason=exc.reason
        ) from exc
    return payload, encoding_for(tp)


@overload
def decode(payload: bytes | bytearray | memoryview, encoding: str | None, expected: type[M]) -> M: ...
@overload
def decode(payload: bytes | bytearray | memoryview, encoding: str | None = None, expected: None = None) -> Message: ...


def decode(
    payload: bytes | bytearray | memoryview,
    encoding: str | None = None,
    expected: type[Message] | None = None,
) -> Message:
    """Decode and validate a payload.

    Parameters
    ----------
    payload : bytes-like
        The JSON payload as received.
    encoding : str or None
        The Zenoh encoding string; names the type and version. When None,
        ``expected`` gives the type.
    expected : type or None
        The type the caller accepts on this key; a different type in ``encoding``
        is rejected.

    Returns
    -------
    Message
        A valid instance of the named type (of ``expected``, when given).

    Raises
    ------
    ProtocolError
        Always and only this, whatever the input: oversized payload (checked before
        parsing), bad encoding string, type mismatch, malformed JSON, or a value
        that breaks a rule (the message includes msgspec's ``$.field`` path and
        ``.field`` is set when a field is to blame).
    """
    try:
        size = memoryview(payload).nbytes
    except TypeError:
        raise ProtocolError(
            f"payload must be bytes-like, got {type(payload).__name__}", reason="malformed"
        ) from None
    if size > MAX_PAYLOAD_BYTES:
        raise ProtocolError(
            f"payload of {size} bytes exceeds MAX_PAYLOAD_BYTES={MAX_PAYLOAD_BYTES}",
            reason="oversize",
        )
    if encoding is None:
        if expected is None:
            raise ProtocolError(
                "no encoding and no expected type: cannot tell the message type",
                reason="encoding",
            )
        return _decode_any_version(payload, _registered(expected))
    tp, version = wire_version(encoding)
    if expected is not None and tp is not expected:
        name = getattr(expected, "__name__", repr(expected))
        raise ProtocolError(
            f"expected {name} but the encoding {encoding!r} names {tp.__name__}",
            reason="unexpected_type",
        )
    if version != tp.VERSION:
        return _decode_legacy(payload, _LEGACY[(tp, version)])
    return _decode_as(payload, tp)


def json_schema(tp: type[Message], version: int | None = None) -> bytes:
    """JSON Schema of a message type (msgspec.json.schema), as JSON bytes, for MCAP: of its current
    version, or of the earlier ``version`` the codec reads."""
    tp = _registered(tp)
    if version is None or version == tp.VERSION:
        return msgspec.json.encode(msgspec.json.schema(tp))
    old = _LEGACY.get((tp, version))
    if old is None:
        raise ProtocolError(f"no version {version} of {tp.__name__}", reason="encoding")
    return msgspec.json.encode(msgspec.json.schema(old.struct))
